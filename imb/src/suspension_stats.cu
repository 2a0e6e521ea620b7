// The suspension statistics of imb/suspension.hpp on the particles' backend:
// one reduction over the particles for velocities, variances, drag and
// weights, and per filter width a binning of the particle volumes into coarse
// cells (integer atomics: the sums do not depend on the order) followed by a
// reduction over the coarse cells. A sample reads back a few dozen numbers.
#include <cmath>
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

// Coarse cells of every filter width, one after the other in `bins`.
struct BinLayout {
  static constexpr int kMaxWidths = 8;
  int widths = 0;
  long n[kMaxWidths][3] = {};
  long offset[kMaxWidths] = {};
  double lo[3] = {0, 0, 0}, len[3] = {1, 1, 1};
};

struct BinParticles {
  dem::ParticleView p;
  int dim;
  BinLayout b;
  unsigned long long* bins;
  LBDEM_HD void operator()(Index i) const {
    const double x[3] = {p.pos_r[i].x, p.pos_r[i].y, p.pos_r[i].z};
    const unsigned long long q =
        static_cast<unsigned long long>(volume_of(p.pos_r[i].w, dim) / kVolumeQuantum + 0.5);
    for (int w = 0; w < b.widths; ++w) {
      long c[3] = {0, 0, 0};
      for (int a = 0; a < 3; ++a) {
        double s = (x[a] - b.lo[a]) / b.len[a];
        s -= floor(s);  // periodic images and centres a hair outside the box
        long k = static_cast<long>(s * double(b.n[w][a]));
        c[a] = k < 0 ? 0 : (k >= b.n[w][a] ? b.n[w][a] - 1 : k);
      }
      atomic_add_u64(bins + b.offset[w] + c[0] + b.n[w][0] * (c[1] + b.n[w][1] * c[2]), q);
    }
  }
};

struct ZeroBins {
  unsigned long long* bins;
  LBDEM_HD void operator()(Index i) const { bins[i] = 0; }
};

struct Moments {
  double s = 0, ss = 0;
};
struct MomentsOp {
  LBDEM_HD Moments operator()(const Moments& a, const Moments& b) const { return {a.s + b.s, a.ss + b.ss}; }
};
struct BinMoments {
  const unsigned long long* bins;
  double scale;  // solid fraction per quantum
  LBDEM_HD Moments operator()(Index i) const {
    const double phi = double(bins[i]) * scale;
    return {phi, phi * phi};
  }
};

std::string width_tag(double w) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", w);
  return b;
}

}  // namespace

struct SuspensionStatistics::Impl {
  Exec ex;
  Scratch scratch;
  Buffer<unsigned long long> bins;
  BinLayout layout;
  double box_volume = 1;
};

SuspensionStatistics::SuspensionStatistics(const Exec& ex, const SuspensionStatsSpec& spec)
    : spec_(spec), impl_(std::make_unique<Impl>()) {
  impl_->ex = ex;
  if (spec_.filter_widths.size() > static_cast<std::size_t>(BinLayout::kMaxWidths))
    throw ConfigError("suspension statistics: at most " + std::to_string(BinLayout::kMaxWidths) + " filter widths");
  BinLayout& b = impl_->layout;
  b.widths = static_cast<int>(spec_.filter_widths.size());
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = double(spec_.fluid_lo[static_cast<std::size_t>(a)]);
    b.len[a] = double(spec_.fluid_hi[static_cast<std::size_t>(a)] - spec_.fluid_lo[static_cast<std::size_t>(a)]);
    impl_->box_volume *= b.len[a];
  }
  long total = 0;
  for (int w = 0; w < b.widths; ++w) {
    const double width = spec_.filter_widths[static_cast<std::size_t>(w)] * spec_.diameter;
    long cells = 1;
    for (int a = 0; a < 3; ++a) {
      // Whole coarse cells of about the filter width (at least one) per axis;
      // a 2D scene's slab is one coarse cell thick.
      const long n = a < spec_.dim ? std::max<long>(1, static_cast<long>(std::floor(b.len[a] / width))) : 1;
      b.n[w][a] = n;
      cells *= n;
    }
    b.offset[w] = total;
    total += cells;
  }
  impl_->bins = Buffer<unsigned long long>(ex.backend(), std::max<long>(1, total));
}

SuspensionStatistics::~SuspensionStatistics() = default;

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
  // Coarse-grained solid fraction per filter width.
  const BinLayout& b = m.layout;
  const Index nbins = m.bins.size();
  for_each(m.ex, nbins, ZeroBins{m.bins.data()});
  if (v.n > 0) for_each(m.ex, v.n, BinParticles{v, dim, b, m.bins.data()});
  if (ranks) {
    // The bins hold whole quanta: their sum over ranks is exact in doubles
    // (below 2^53), and the moments below see the one-rank bins.
    m.ex.synchronize();
    std::vector<unsigned long long> h(static_cast<std::size_t>(nbins));
    m.bins.copy_to_host(h.data(), nbins);
    std::vector<double> hd(h.begin(), h.end());
    spec_.comm->sum(hd);
    for (std::size_t i = 0; i < h.size(); ++i) h[i] = static_cast<unsigned long long>(hd[i]);
    m.bins.copy_from_host(h.data(), nbins);
  }
  const double mean_vol = ps.n > 0 ? ps.vol / ps.n : 0;
  for (int w = 0; w < b.widths; ++w) {
    const long cells = b.n[w][0] * b.n[w][1] * b.n[w][2];
    const double vbin = m.box_volume / double(cells);
    const Moments mo = transform_reduce(m.ex, cells, Moments{}, MomentsOp{},
                                        BinMoments{m.bins.data() + b.offset[w], kVolumeQuantum / vbin}, m.scratch);
    const double mean = mo.s / double(cells);
    const double var = std::max(0.0, mo.ss / double(cells) - mean * mean);
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
