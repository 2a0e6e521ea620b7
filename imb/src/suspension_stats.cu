// The suspension statistics of imb/suspension.hpp on the particles' backend:
// one reduction over the particles for velocities, variances, drag and
// weights, and per filter width a binning of the particle volumes into coarse
// cells (integer atomics: the sums do not depend on the order) followed by
// exact integer moments over the coarse cells. On several ranks each rank
// holds only the coarse cells near its own piece (never the whole domain's):
// the counts of cells that straddle a cut go to their owners, and the
// moments are one small sum over ranks.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "imb/suspension.hpp"
#include "core/algorithms.hpp"
#include "core/buffer.hpp"
#include "core/hd.hpp"
#include "halo/comm.hpp"

namespace lbdem::imb {

namespace {

// Particle volumes are binned in fixed point (units of 2^-20 cell volumes):
// exact integer sums whatever the order of the atomics.
constexpr double kVolumeQuantum = 1.0 / 1048576.0;

struct ParticleSums {
  double n = 0;
  double v[3] = {0, 0, 0}, vv[3] = {0, 0, 0};
  double drag[3] = {0, 0, 0};
  double vol = 0, vol_v[3] = {0, 0, 0};
  double mom[3] = {0, 0, 0};
  double net_mass = 0;  // sum (m - rho_f V_p), m the DEM mass
};

struct SumOp {
  LBDEM_HD ParticleSums operator()(const ParticleSums& a, const ParticleSums& b) const {
    ParticleSums r;
    r.n = a.n + b.n;
    for (int k = 0; k < 3; ++k) {
      r.v[k] = a.v[k] + b.v[k];
      r.vv[k] = a.vv[k] + b.vv[k];
      r.drag[k] = a.drag[k] + b.drag[k];
      r.vol_v[k] = a.vol_v[k] + b.vol_v[k];
      r.mom[k] = a.mom[k] + b.mom[k];
    }
    r.vol = a.vol + b.vol;
    r.net_mass = a.net_mass + b.net_mass;
    return r;
  }
};

LBDEM_HD inline double volume_of(double r, int dim) {
  return dim == 3 ? 4.18879020478639098 * r * r * r : 3.14159265358979324 * r * r;
}

// One particle's contribution. Held particles (inverse mass ~0) count in the
// velocity and volume sums but carry no momentum and no weight.
struct ParticleTerm {
  dem::ParticleView p;
  int dim;
  double rho_f;
  double buoy[3];  // rho_f g when ext_force holds the buoyancy, else 0
  LBDEM_HD ParticleSums operator()(Index i) const {
    ParticleSums s;
    const double r = p.pos_r[i].w, im = p.vel_im[i].w;
    const double v[3] = {p.vel_im[i].x, p.vel_im[i].y, p.vel_im[i].z};
    const double f[3] = {p.ext_force[i].x, p.ext_force[i].y, p.ext_force[i].z};
    const double vol = volume_of(r, dim);
    const bool held = !(im > 1e-200);
    const double m = held ? 0.0 : 1.0 / im;
    // The net mass: the DEM mass (a disk's in a 2D scene) less the displaced fluid.
    s.n = 1;
    for (int k = 0; k < 3; ++k) {
      s.v[k] = v[k];
      s.vv[k] = v[k] * v[k];
      s.drag[k] = f[k] + vol * buoy[k];
      s.vol_v[k] = vol * v[k];
      s.mom[k] = m * v[k];
    }
    s.vol = vol;
    s.net_mass = held ? 0.0 : m - rho_f * vol;
    return s;
  }
};

LBDEM_HD inline void atomic_add_u64(unsigned long long* p, unsigned long long v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(p, v);
#else
  __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

// Coarse cells of every filter width. Width w has n[w][a] coarse cells along
// axis a over the fluid box, coarse cell k spanning [lo + k len / n,
// lo + (k + 1) len / n). A rank holds a box of them per width: ext[w][a] cells
// from klo[w][a] on (unwrapped: on a periodic axis coarse cell k is held as
// the one of k, k - n, k + n that falls in the box; ext <= n), one box after
// the other in `bins` (offset[w]).
struct BinLayout {
  static constexpr int kMaxWidths = 8;
  int widths = 0;
  long n[kMaxWidths][3] = {};
  long klo[kMaxWidths][3] = {};
  long ext[kMaxWidths][3] = {};
  long offset[kMaxWidths] = {};
  double lo[3] = {0, 0, 0}, len[3] = {1, 1, 1};
};

// Each particle's volume (in quanta) to the coarse cell of its centre, in
// the rank's box; a centre whose coarse cell the box misses counts in *stray.
struct BinParticles {
  dem::ParticleView p;
  int dim;
  BinLayout b;
  unsigned long long* bins;
  unsigned long long* stray;
  LBDEM_HD void operator()(Index i) const {
    const double x[3] = {p.pos_r[i].x, p.pos_r[i].y, p.pos_r[i].z};
    const unsigned long long q =
        static_cast<unsigned long long>(volume_of(p.pos_r[i].w, dim) / kVolumeQuantum + 0.5);
    for (int w = 0; w < b.widths; ++w) {
      long c[3] = {0, 0, 0};
      bool in = true;
      for (int a = 0; a < 3; ++a) {
        double s = (x[a] - b.lo[a]) / b.len[a];
        s -= floor(s);  // periodic images and centres a hair outside the box
        const long n = b.n[w][a];
        long k = static_cast<long>(s * double(n));
        k = k < 0 ? 0 : (k >= n ? n - 1 : k);
        long d = (k - b.klo[w][a]) % n;  // the held image of k
        if (d < 0) d += n;
        in = in && d < b.ext[w][a];
        c[a] = d;
      }
      if (in) atomic_add_u64(bins + b.offset[w] + c[0] + b.ext[w][0] * (c[1] + b.ext[w][1] * c[2]), q);
      else atomic_add_u64(stray, 1);
    }
  }
};

struct ZeroBins {
  unsigned long long* bins;
  LBDEM_HD void operator()(Index i) const { bins[i] = 0; }
};

std::string width_tag(double w) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", w);
  return b;
}

}  // namespace

namespace {

long floor_div(long a, long b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// The coarse cells [klo, klo + ext) along one axis of `n` over the fluid box
// [lo, lo + len) that a rank whose piece spans cells [plo, phi) holds: those
// within `margin` cells of the piece, rounded out to whole coarse cells; the
// whole axis when that spans it; never beyond a closed face.
void held_range(long n, long lo, long len, long plo, long phi, long margin, bool periodic, long& klo, long& ext) {
  long k0 = floor_div((plo - margin - lo) * n, len);
  long k1 = -floor_div(-(phi + margin - lo) * n, len);  // ceiling
  if (!periodic) {
    k0 = std::max(k0, 0L);
    k1 = std::min(k1, n);
  }
  if (k1 - k0 >= n) {
    k0 = 0;
    k1 = n;
  }
  klo = k0;
  ext = std::max(k1 - k0, 0L);
}

// The first cell of coarse cell k (0 <= k < n): its owner is the rank whose piece holds it.
long anchor_cell(long k, long n, long lo, long len) { return lo + k * len / n; }

long wrap(long k, long n) { return (k % n + n) % n; }

}  // namespace

struct SuspensionStatistics::Impl {
  Exec ex;
  Scratch scratch;
  Buffer<unsigned long long> bins;   // the held coarse cells of every width (BinLayout)
  Buffer<unsigned long long> stray;  // particles whose coarse cell this rank does not hold
  BinLayout layout;
  double box_volume = 1;
  int rank = 0, ranks = 1;
  // Global coarse cells of the widths before w (all widths in one index space, for the exchange).
  long global_offset[BinLayout::kMaxWidths] = {};
  // Per width and axis, the held coarse cells (local index) whose first cell lies in this rank's piece.
  std::vector<char> owned[BinLayout::kMaxWidths][3];
  std::vector<std::array<long, 3>> plo, phi;  // every rank's piece [plo, phi) in cells
  std::vector<int> peers;  // ranks that hold coarse cells this rank owns, or own some it holds
  std::vector<unsigned long long> host;  // the held coarse cells on the host
  std::vector<std::vector<std::byte>> sends;

  int owner_of(const long k[3], int w) const {
    long c[3];
    for (int a = 0; a < 3; ++a) c[a] = anchor_cell(k[a], layout.n[w][a], long(layout.lo[a]), long(layout.len[a]));
    for (int r = 0; r < ranks; ++r) {
      const auto& l = plo[static_cast<std::size_t>(r)];
      const auto& h = phi[static_cast<std::size_t>(r)];
      if (c[0] >= l[0] && c[0] < h[0] && c[1] >= l[1] && c[1] < h[1] && c[2] >= l[2] && c[2] < h[2]) return r;
    }
    return -1;
  }
  bool owns(int w, const long d[3]) const {
    return owned[w][0][static_cast<std::size_t>(d[0])] && owned[w][1][static_cast<std::size_t>(d[1])] &&
           owned[w][2][static_cast<std::size_t>(d[2])];
  }
  std::size_t local_index(int w, const long d[3]) const {
    return static_cast<std::size_t>(layout.offset[w] + d[0] + layout.ext[w][0] * (d[1] + layout.ext[w][1] * d[2]));
  }
};

SuspensionStatistics::SuspensionStatistics(const Exec& ex, const SuspensionStatsSpec& spec)
    : spec_(spec), impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.ex = ex;
  if (spec_.filter_widths.size() > static_cast<std::size_t>(BinLayout::kMaxWidths))
    throw ConfigError("suspension statistics: at most " + std::to_string(BinLayout::kMaxWidths) + " filter widths");
  BinLayout& b = m.layout;
  b.widths = static_cast<int>(spec_.filter_widths.size());
  long flo[3], flen[3];
  for (int a = 0; a < 3; ++a) {
    flo[a] = spec_.fluid_lo[static_cast<std::size_t>(a)];
    flen[a] = spec_.fluid_hi[static_cast<std::size_t>(a)] - flo[a];
    b.lo[a] = double(flo[a]);
    b.len[a] = double(flen[a]);
    m.box_volume *= b.len[a];
  }
  // Every rank's piece; one piece: the fluid box.
  const bool distributed = spec_.comm && spec_.comm->distributed();
  m.rank = distributed ? spec_.comm->rank() : 0;
  m.ranks = distributed ? spec_.comm->size() : 1;
  if (distributed) {
    if (spec_.piece_offset.size() != static_cast<std::size_t>(m.ranks) ||
        spec_.piece_cells.size() != spec_.piece_offset.size())
      throw Error("suspension statistics: " + std::to_string(spec_.piece_offset.size()) + " pieces given for " +
                  std::to_string(m.ranks) + " ranks");
    for (int r = 0; r < m.ranks; ++r) {
      const auto& o = spec_.piece_offset[static_cast<std::size_t>(r)];
      const auto& c = spec_.piece_cells[static_cast<std::size_t>(r)];
      m.plo.push_back(o);
      m.phi.push_back({o[0] + c[0], o[1] + c[1], o[2] + c[2]});
    }
  } else {
    m.plo.push_back({flo[0], flo[1], flo[2]});
    m.phi.push_back({flo[0] + flen[0], flo[1] + flen[1], flo[2] + flen[2]});
  }
  // A particle belongs to the rank whose piece held its centre when the DEM
  // last sorted the particles, and moves less than its skin between sorts:
  // a diameter of margin holds the coarse cell of every centre a rank owns.
  const long margin = std::max<long>(1, static_cast<long>(std::ceil(spec_.diameter)));
  auto piece_lo = [&](int r, int a) { return m.plo[static_cast<std::size_t>(r)][static_cast<std::size_t>(a)]; };
  auto piece_hi = [&](int r, int a) { return m.phi[static_cast<std::size_t>(r)][static_cast<std::size_t>(a)]; };
  auto held = [&](int r, int w, int a, long& klo, long& ext) {
    held_range(b.n[w][a], flo[a], flen[a], piece_lo(r, a), piece_hi(r, a), margin,
               spec_.periodic[static_cast<std::size_t>(a)], klo, ext);
  };
  // Does rank r own coarse cell klo + d (of width w along axis a)?
  auto owns_at = [&](int r, int w, int a, long k) {
    const long c = anchor_cell(wrap(k, b.n[w][a]), b.n[w][a], flo[a], flen[a]);
    return c >= piece_lo(r, a) && c < piece_hi(r, a);
  };
  auto owns_some = [&](int r, int w, int a, long klo, long ext) {
    for (long d = 0; d < ext; ++d)
      if (owns_at(r, w, a, klo + d)) return true;
    return false;
  };
  long total = 0, global = 0;
  for (int w = 0; w < b.widths; ++w) {
    const double width = spec_.filter_widths[static_cast<std::size_t>(w)] * spec_.diameter;
    long cells = 1, all = 1;
    for (int a = 0; a < 3; ++a) {
      // Whole coarse cells of about the filter width (at least one) per axis;
      // a 2D scene's slab is one coarse cell thick.
      const long n = a < spec_.dim ? std::max<long>(1, static_cast<long>(std::floor(b.len[a] / width))) : 1;
      b.n[w][a] = n;
      held(m.rank, w, a, b.klo[w][a], b.ext[w][a]);
      cells *= b.ext[w][a];
      all *= n;
      auto& own = m.owned[w][a];
      own.assign(static_cast<std::size_t>(b.ext[w][a]), 0);
      for (long d = 0; d < b.ext[w][a]; ++d) own[static_cast<std::size_t>(d)] = owns_at(m.rank, w, a, b.klo[w][a] + d);
    }
    b.offset[w] = total;
    m.global_offset[w] = global;
    total += cells;
    global += all;
  }
  // Peers: this rank holds a coarse cell rank r owns, or r holds one this
  // rank owns (both ways: each pair exchanges one message, empty or not).
  for (int r = 0; distributed && r < m.ranks; ++r) {
    if (r == m.rank) continue;
    bool peer = false;
    for (int w = 0; w < b.widths && !peer; ++w) {
      bool to = true, from = true;
      for (int a = 0; a < 3; ++a) {
        long klo = 0, ext = 0;
        held(r, w, a, klo, ext);
        to = to && owns_some(r, w, a, b.klo[w][a], b.ext[w][a]);
        from = from && owns_some(m.rank, w, a, klo, ext);
      }
      peer = to || from;
    }
    if (peer) m.peers.push_back(r);
  }
  m.bins = Buffer<unsigned long long>(ex.backend(), std::max<long>(1, total));
  m.stray = Buffer<unsigned long long>(ex.backend(), 1);
  m.host.resize(static_cast<std::size_t>(std::max<long>(1, total)));
  m.sends.resize(m.peers.size());
}

SuspensionStatistics::~SuspensionStatistics() = default;

Index SuspensionStatistics::bins_held() const {
  const BinLayout& b = impl_->layout;
  Index n = 0;
  for (int w = 0; w < b.widths; ++w) n += b.ext[w][0] * b.ext[w][1] * b.ext[w][2];
  return n;
}

SuspensionSample SuspensionStatistics::sample(dem::DemSystem& dem, const lbm::LbmDiagnostics& d) {
  Impl& m = *impl_;
  dem.synchronize();  // the DEM's stream has finished the step being sampled
  const dem::ParticleView v = dem.view();
  SuspensionSample s;
  const int dim = spec_.dim;
  ParticleSums ps;
  if (v.n > 0 && v.ext_force) {
    ParticleTerm t{v, dim, spec_.fluid_density, {0, 0, 0}};
    if (spec_.buoyancy)
      for (int k = 0; k < 3; ++k) t.buoy[k] = spec_.fluid_density * spec_.gravity[static_cast<std::size_t>(k)];
    ps = transform_reduce(m.ex, v.n, ParticleSums{}, SumOp{}, t, m.scratch);
  }
  const bool ranks = spec_.comm && spec_.comm->distributed();
  if (ranks) {
    // Every rank sums its own particles; the sums over ranks in rank order.
    std::vector<double> a{ps.n, ps.vol, ps.net_mass};
    for (const double* q : {ps.v, ps.vv, ps.drag, ps.vol_v, ps.mom}) a.insert(a.end(), q, q + 3);
    spec_.comm->sum(a);
    ps.n = a[0];
    ps.vol = a[1];
    ps.net_mass = a[2];
    std::size_t k = 3;
    for (double* q : {ps.v, ps.vv, ps.drag, ps.vol_v, ps.mom})
      for (int c = 0; c < 3; ++c) q[c] = a[k++];
  }
  const double n = ps.n > 0 ? ps.n : 1;
  s.fluid_volume = m.box_volume - ps.vol;
  for (int k = 0; k < 3; ++k) {
    const auto a = static_cast<std::size_t>(k);
    s.particle_velocity[a] = ps.v[k] / n;
    s.velocity_variance[a] = std::max(0.0, ps.vv[k] / n - s.particle_velocity[a] * s.particle_velocity[a]);
    s.drag[a] = ps.drag[k];
    s.drag_per_particle[a] = ps.drag[k] / n;
    s.particle_momentum[a] = ps.mom[k];
    // Fluid momentum over the fluid volume: the lattice momentum sum with the
    // half-step shift of the body force (Guo forcing, u = (sum c f + F/2) / rho),
    // less the fluid that moves with the particles inside them (rho_f V_p v_p,
    // the PSM's rigid-body motion in covered cells).
    const double mom = d.momentum[a] + 0.5 * spec_.body_force[a] * s.fluid_volume - spec_.fluid_density * ps.vol_v[k];
    s.fluid_velocity[a] = s.fluid_volume > 0 ? mom / (spec_.fluid_density * s.fluid_volume) : 0.0;
    s.slip[a] = s.fluid_velocity[a] - s.particle_velocity[a];
  }
  for (int k = 0; k < dim; ++k) s.granular_temperature += s.velocity_variance[static_cast<std::size_t>(k)] / dim;
  const auto& g = spec_.gravity;
  const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (gn > 0 && ps.net_mass != 0) {
    const double along = -(ps.drag[0] * g[0] + ps.drag[1] * g[1] + ps.drag[2] * g[2]) / gn;
    s.drag_over_weight = along / (ps.net_mass * gn);
  }
  // Coarse-grained solid fraction per filter width: each rank bins its own
  // particles into the coarse cells it holds, sends the counts of those it
  // does not own to their owners, and sums over those it owns. The counts
  // are whole quanta and the moments exact integers (sum q and sum q^2 in 128
  // bits), summed over ranks exactly: the same bits on any rank count.
  const BinLayout& b = m.layout;
  const Index nbins = m.bins.size();
  for_each(m.ex, nbins, ZeroBins{m.bins.data()});
  for_each(m.ex, 1, ZeroBins{m.stray.data()});
  if (v.n > 0) for_each(m.ex, v.n, BinParticles{v, dim, b, m.bins.data(), m.stray.data()});
  m.ex.synchronize();
  unsigned long long stray = 0;
  m.stray.copy_to_host(&stray, 1);
  if (stray > 0)
    throw Error("suspension statistics: " + std::to_string(stray) + " particle centre(s) lie more than a diameter "
                "outside the piece of the rank that owns them (rank " + std::to_string(m.rank) + ")");
  m.bins.copy_to_host(m.host.data(), nbins);
  if (ranks) {
    for (auto& q : m.sends) q.clear();
    for (int w = 0; w < b.widths; ++w) {
      long d[3];
      for (d[2] = 0; d[2] < b.ext[w][2]; ++d[2])
        for (d[1] = 0; d[1] < b.ext[w][1]; ++d[1])
          for (d[0] = 0; d[0] < b.ext[w][0]; ++d[0]) {
            const unsigned long long q = m.host[m.local_index(w, d)];
            if (q == 0 || m.owns(w, d)) continue;
            long k[3];
            for (int a = 0; a < 3; ++a) k[a] = wrap(b.klo[w][a] + d[a], b.n[w][a]);
            const int owner = m.owner_of(k, w);
            const auto at = std::find(m.peers.begin(), m.peers.end(), owner);
            if (at == m.peers.end())
              throw Error("suspension statistics: a coarse cell of rank " + std::to_string(m.rank) +
                          " belongs to rank " + std::to_string(owner) + ", not one of its peers");
            const unsigned long long pair[2] = {
                static_cast<unsigned long long>(m.global_offset[w] + k[0] + b.n[w][0] * (k[1] + b.n[w][1] * k[2])), q};
            auto& out = m.sends[static_cast<std::size_t>(at - m.peers.begin())];
            const auto* bytes = reinterpret_cast<const std::byte*>(pair);
            out.insert(out.end(), bytes, bytes + sizeof pair);
          }
    }
    constexpr int kTag = 4711;
    const std::vector<int> tags(m.peers.size(), kTag);
    const auto got = spec_.comm->exchange(m.peers, tags, m.sends, tags);
    for (const auto& msg : got)
      for (std::size_t o = 0; o + 2 * sizeof(unsigned long long) <= msg.size(); o += 2 * sizeof(unsigned long long)) {
        unsigned long long pair[2];
        std::memcpy(pair, msg.data() + o, sizeof pair);
        int w = b.widths - 1;
        while (w > 0 && static_cast<long>(pair[0]) < m.global_offset[w]) --w;
        long g = static_cast<long>(pair[0]) - m.global_offset[w], d[3];
        bool mine = true;
        for (int a = 0; a < 3; ++a) {
          const long k = g % b.n[w][a];
          g /= b.n[w][a];
          d[a] = wrap(k - b.klo[w][a], b.n[w][a]);
          mine = mine && d[a] < b.ext[w][a];
        }
        if (!mine || !m.owns(w, d))
          throw Error("suspension statistics: rank " + std::to_string(m.rank) + " received a coarse cell it does not own");
        m.host[m.local_index(w, d)] += pair[1];
      }
  }
  // Exact sums over the owned coarse cells, over ranks in 32-bit limbs (a
  // limb's sum stays below 2^53 up to 2^21 ranks: exact in double).
  constexpr int kLimbs = 6;  // sum q: 2 limbs; sum q^2: 4
  std::vector<double> limbs(static_cast<std::size_t>(kLimbs * b.widths), 0.0);
  for (int w = 0; w < b.widths; ++w) {
    unsigned long long sum = 0;
    unsigned __int128 sum2 = 0;
    long d[3];
    for (d[2] = 0; d[2] < b.ext[w][2]; ++d[2])
      for (d[1] = 0; d[1] < b.ext[w][1]; ++d[1])
        for (d[0] = 0; d[0] < b.ext[w][0]; ++d[0]) {
          if (!m.owns(w, d)) continue;
          const unsigned long long q = m.host[m.local_index(w, d)];
          sum += q;
          sum2 += static_cast<unsigned __int128>(q) * q;
        }
    double* l = limbs.data() + kLimbs * w;
    l[0] = double(sum & 0xffffffffULL);
    l[1] = double(sum >> 32);
    for (int j = 0; j < 4; ++j) l[2 + j] = double(static_cast<unsigned long long>(sum2 >> (32 * j)) & 0xffffffffULL);
  }
  if (ranks) spec_.comm->sum(limbs);
  const double mean_vol = ps.n > 0 ? ps.vol / ps.n : 0;
  for (int w = 0; w < b.widths; ++w) {
    const double* l = limbs.data() + kLimbs * w;
    auto limb = [&](int j) { return static_cast<unsigned __int128>(static_cast<unsigned long long>(l[j])); };
    const unsigned __int128 sum = limb(0) + (limb(1) << 32);
    const unsigned __int128 sum2 = limb(2) + (limb(3) << 32) + (limb(4) << 64) + (limb(5) << 96);
    const long cells = b.n[w][0] * b.n[w][1] * b.n[w][2];
    const double vbin = m.box_volume / double(cells);
    const double scale = kVolumeQuantum / vbin;  // solid fraction per quantum
    const double mean = static_cast<double>(sum) * scale / double(cells);
    const double var = std::max(0.0, static_cast<double>(sum2) * (scale * scale) / double(cells) - mean * mean);
    // Independently placed particles: a Poisson count per coarse cell, so the
    // variance of the fraction is (mean count) (V_p / V_bin)^2 = phi V_p / V_bin.
    const double random_var = mean * mean_vol / vbin;
    s.phi_variance.push_back(var);
    s.phi_variance_rel.push_back(random_var > 0 ? var / random_var : 0.0);
    s.bins.push_back({b.n[w][0], b.n[w][1], b.n[w][2]});
  }
  return s;
}

std::vector<std::string> SuspensionStatistics::columns() const {
  std::vector<std::string> c = {"fluid_ux", "fluid_uy", "fluid_uz", "particle_vx", "particle_vy", "particle_vz",
                                "slip_x", "slip_y", "slip_z", "drag_x", "drag_y", "drag_z",
                                "drag_per_particle_x", "drag_per_particle_y", "drag_per_particle_z",
                                "drag_over_weight", "var_vx", "var_vy", "var_vz", "granular_temperature",
                                "particle_momentum_x", "particle_momentum_y", "particle_momentum_z"};
  for (double w : spec_.filter_widths) {
    c.push_back("phi_var_" + width_tag(w) + "d");
    c.push_back("phi_var_rel_" + width_tag(w) + "d");
  }
  return c;
}

std::vector<double> SuspensionStatistics::row(const SuspensionSample& s) const {
  std::vector<double> r;
  for (const auto* a : {&s.fluid_velocity, &s.particle_velocity, &s.slip, &s.drag, &s.drag_per_particle})
    r.insert(r.end(), a->begin(), a->end());
  r.push_back(s.drag_over_weight);
  r.insert(r.end(), s.velocity_variance.begin(), s.velocity_variance.end());
  r.push_back(s.granular_temperature);
  r.insert(r.end(), s.particle_momentum.begin(), s.particle_momentum.end());
  for (std::size_t w = 0; w < s.phi_variance.size(); ++w) {
    r.push_back(s.phi_variance[w]);
    r.push_back(s.phi_variance_rel[w]);
  }
  return r;
}

}  // namespace lbdem::imb
