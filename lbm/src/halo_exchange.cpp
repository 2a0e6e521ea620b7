#include "lbm/halo_exchange.hpp"

#include <chrono>
#include <string>

#include "core/error.hpp"
#include "lbm/lattice.hpp"

namespace lbdem::lbm {
namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int dir_index(const std::array<int, 3>& d) { return (d[0] + 1) + 3 * (d[1] + 1) + 9 * (d[2] + 1); }

// Storage range along axis a of the ghost layer on side r (-1, +1) or of the
// owned range (0).
void ghost_range(const Grid& p, int a, int r, int& lo, int& ext) {
  const int g = p.ghost_on(a);
  const int n = static_cast<int>(p.local[static_cast<std::size_t>(a)]);
  if (r < 0) { lo = 0; ext = g; }
  else if (r > 0) { lo = g + n; ext = g; }
  else { lo = g; ext = n; }
}
// The owned layer next to side r (one cell thick), or the owned range (0).
void layer_range(const Grid& p, int a, int r, int& lo, int& ext) {
  const int g = p.ghost_on(a);
  const int n = static_cast<int>(p.local[static_cast<std::size_t>(a)]);
  if (r < 0) { lo = g; ext = 1; }
  else if (r > 0) { lo = g + n - 1; ext = 1; }
  else { lo = g; ext = n; }
}

// Slots q whose velocity has c_a == sign * r_a on every axis where r_a != 0.
template <class L>
void choose_slots(const std::array<int, 3>& r, int sign, HaloBlock& b) {
  b.slots = 0;
  for (int q = 0; q < L::Q; ++q) {
    bool ok = true;
    for (int a = 0; a < 3; ++a)
      if (r[static_cast<std::size_t>(a)] != 0 && L::c(q, a) != sign * r[static_cast<std::size_t>(a)]) ok = false;
    if (!ok) continue;
    if (b.slots >= kMaxHaloSlots) throw Error("halo: more slots cross a face than a halo block holds");
    b.q[b.slots] = q;
    for (int a = 0; a < 3; ++a) b.c[b.slots][a] = L::c(q, a);
    ++b.slots;
  }
}

template <class L>
std::vector<HaloLink> links_for(const halo::Decomposition& dec, int rank, const Grid& p) {
  std::vector<HaloLink> out;
  const auto me = dec.coords(rank);
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const std::array<int, 3> r{dx, dy, dz};
        if (dx == 0 && dy == 0 && dz == 0) continue;
        bool ok = true;
        std::array<int, 3> nc = me;
        for (int a = 0; a < 3; ++a) {
          const auto ua = static_cast<std::size_t>(a);
          if (r[ua] == 0) continue;
          if (!p.split[ua]) { ok = false; break; }  // no ghosts on that axis
          nc[ua] += r[ua];
          if (nc[ua] < 0 || nc[ua] >= dec.dims[ua]) {
            if (!dec.periodic[ua]) { ok = false; break; }  // beyond a walled end
            nc[ua] = (nc[ua] + dec.dims[ua]) % dec.dims[ua];
          }
        }
        if (!ok) continue;
        HaloLink k;
        k.dir = r;
        k.peer = dec.rank_at(nc);
        k.tag = dir_index(r);
        k.recv_tag = dir_index({-dx, -dy, -dz});
        CellBox layer, ghost;
        for (int a = 0; a < 3; ++a) {
          layer_range(p, a, r[static_cast<std::size_t>(a)], layer.lo[a], layer.ext[a]);
          ghost_range(p, a, r[static_cast<std::size_t>(a)], ghost.lo[a], ghost.ext[a]);
        }
        // Two-lattice: the receiver (across r, its region -r) pulls c = -(-r) = r.
        k.send_fill_tl.box = layer;
        choose_slots<L>(r, +1, k.send_fill_tl);
        k.send_fill_tl.second = true;  // the new populations, before the swap
        k.recv_fill_tl = k.send_fill_tl;
        k.recv_fill_tl.box = ghost;
        choose_slots<L>(r, -1, k.recv_fill_tl);
        // A-A before an odd step: the receiver reads c = its region = -r.
        k.send_fill_aa.box = layer;
        choose_slots<L>(r, -1, k.send_fill_aa);
        k.recv_fill_aa = k.send_fill_aa;
        k.recv_fill_aa.box = ghost;
        choose_slots<L>(r, +1, k.recv_fill_aa);
        // A-A after an odd step: my cells wrote c = r into ghost region r; the
        // sender across r wrote c = -r into the layer facing it.
        k.send_back.box = ghost;
        choose_slots<L>(r, +1, k.send_back);
        k.recv_back.box = layer;
        choose_slots<L>(r, -1, k.recv_back);
        k.recv_back.mode = HaloUnpack::WriteBack;
        for (int a = 0; a < 3; ++a) k.recv_back.from[a] = r[static_cast<std::size_t>(a)];
        k.recv_back.owned = p.owned();
        if (k.send_fill_tl.slots == 0) continue;  // e.g. D3Q19 corners
        out.push_back(k);
      }
  return out;
}

}  // namespace

std::vector<HaloLink> halo_links(const halo::Decomposition& dec, int rank, const Grid& piece, LatticeKind kind) {
  return kind == LatticeKind::D2Q9 ? links_for<D2Q9>(dec, rank, piece) : links_for<D3Q19>(dec, rank, piece);
}

FluidHalo::FluidHalo(LbmSolver& solver, const halo::Decomposition& dec, int rank, halo::Transport& transport)
    : s_(solver), tr_(transport) {
  const Grid& p = solver.setup().domain;
  links_ = halo_links(dec, rank, p, solver.setup().lattice);
  outer_ = p.outer(1);
  inner_ = p.inner(1);
  owned_ = p.owned();
  const int tb = solver.storage_bytes();
  std::vector<halo::Message> msgs;
  for (const HaloLink& k : links_) {
    const auto n = static_cast<Index>(k.send_fill_tl.bytes(tb));
    send_.emplace_back(solver.backend(), n);
    recv_.emplace_back(solver.backend(), n);
    halo::Message m;
    m.peer = k.peer;
    m.tag = k.tag;
    m.send = send_.back().data();
    m.send_bytes = static_cast<std::size_t>(n);
    m.recv_tag = k.recv_tag;
    m.recv = recv_.back().data();
    m.recv_bytes = static_cast<std::size_t>(n);
    msgs.push_back(m);
    bytes_ += static_cast<std::size_t>(n);
  }
  messages_ = static_cast<int>(msgs.size());
  tr_.bind(std::move(msgs));
  reset_times();
}

FluidHalo::Phase FluidHalo::phase_of_step() const {
  if (s_.setup().streaming == StreamKind::TwoLattice) return Phase::FillTwoLattice;
  return (s_.steps_done() & 1) == 0 ? Phase::FillAA : Phase::WriteBack;
}

void FluidHalo::pack(Phase ph) {
  for (std::size_t i = 0; i < links_.size(); ++i) {
    const HaloLink& k = links_[i];
    const HaloBlock& b = ph == Phase::FillTwoLattice ? k.send_fill_tl : (ph == Phase::FillAA ? k.send_fill_aa : k.send_back);
    s_.pack_halo(b, send_[i].data());
  }
}

void FluidHalo::unpack(Phase ph) {
  for (std::size_t i = 0; i < links_.size(); ++i) {
    const HaloLink& k = links_[i];
    const HaloBlock& b = ph == Phase::FillTwoLattice ? k.recv_fill_tl : (ph == Phase::FillAA ? k.recv_fill_aa : k.recv_back);
    s_.unpack_halo(b, recv_[i].data());
  }
}

void FluidHalo::begin_fill() {
  if (s_.setup().streaming != StreamKind::TwoLattice || links_.empty()) return;
  // Before any step the incoming populations are in the first array: the
  // blocks that read "the new populations" read it instead.
  s_.fork();
  for (std::size_t i = 0; i < links_.size(); ++i) {
    HaloBlock b = links_[i].send_fill_tl;
    b.second = false;
    s_.pack_halo(b, send_[i].data());
  }
  tr_.start(s_.exec(Lane::Edge));
}

void FluidHalo::finish_fill() {
  if (s_.setup().streaming != StreamKind::TwoLattice || links_.empty()) return;
  tr_.finish(s_.exec(Lane::Edge));
  for (std::size_t i = 0; i < links_.size(); ++i) {
    HaloBlock b = links_[i].recv_fill_tl;
    b.second = false;
    s_.unpack_halo(b, recv_[i].data());
  }
  s_.join();
  s_.synchronize();
}

void FluidHalo::begin_step(ExternalStep* ext) {
  if (in_step_) throw Error("FluidHalo::begin_step called twice without finish_step");
  in_step_ = true;
  ext_ = ext;
  t_begin_ = now();
  phase_ = phase_of_step();
  const Exec& edge = s_.exec(Lane::Edge);
  auto whole = [&] {
    if (ext_) {
      ext_->outer(Lane::Main);
      ext_->inner(Lane::Main);
    } else {
      s_.step_box(owned_);
    }
  };
  if (links_.empty()) {
    whole();
    return;
  }
  if (mode_ == Mode::Serial) {
    whole();
    s_.fork();
    pack(phase_);
    const double t0 = now();
    tr_.start(edge);
    times_.start += now() - t0;
    return;
  }
  s_.fork();
  if (ext_) ext_->outer(Lane::Edge);
  else
    for (const CellBox& b : outer_) s_.step_box(b, Lane::Edge);
  if (mode_ == Mode::Overlap) {
    pack(phase_);
    const double t0 = now();
    tr_.start(edge);
    times_.start += now() - t0;
  }
  if (ext_) ext_->inner(Lane::Main);
  else s_.step_box(inner_, Lane::Main);
}

void FluidHalo::finish_step() {
  if (!in_step_) throw Error("FluidHalo::finish_step called without begin_step");
  in_step_ = false;
  if (!links_.empty()) {
    if (mode_ != Mode::ComputeOnly) {
      const double t0 = now();
      tr_.finish(s_.exec(Lane::Edge));
      times_.finish += now() - t0;
      unpack(phase_);
    }
    s_.join();
  }
  if (ext_) ext_->commit();
  else s_.end_step();
  ext_ = nullptr;
  ++times_.steps;
  times_.total += now() - t_begin_;
}

void FluidHalo::step(long n) {
  for (long i = 0; i < n; ++i) {
    begin_step();
    finish_step();
  }
}

void piece_fields(const Grid& whole, const Grid& piece, const std::vector<std::uint8_t>& flags,
                  const std::vector<double>& rho, const std::vector<double>& u, std::vector<std::uint8_t>& pflags,
                  std::vector<double>& prho, std::vector<double>& pu) {
  const GridView gw = whole.view(), gp = piece.view();
  if (flags.size() != static_cast<std::size_t>(gw.n) || rho.size() != flags.size() || u.size() != 3 * flags.size())
    throw Error("piece_fields: field sizes do not match the whole grid");
  const auto n = static_cast<std::size_t>(gp.n);
  pflags.assign(n, kGhostFlag);
  prho.assign(n, 1.0);
  pu.assign(3 * n, 0.0);
  for (int z = 0; z < gp.nz; ++z)
    for (int y = 0; y < gp.ny; ++y)
      for (int x = 0; x < gp.nx; ++x) {
        const int pc[3] = {x, y, z};
        long w[3];
        bool inside = true, ghost = false;
        for (int a = 0; a < 3; ++a) {
          const auto ua = static_cast<std::size_t>(a);
          w[a] = pc[a] + piece.offset[ua] - piece.ghost_on(a);
          if (pc[a] < piece.ghost_on(a) || pc[a] >= piece.ghost_on(a) + piece.local[ua]) ghost = true;
          if (w[a] < 0 || w[a] >= whole.global[ua]) {
            if (!whole.periodic[ua]) inside = false;
            w[a] = (w[a] % whole.global[ua] + whole.global[ua]) % whole.global[ua];
          }
        }
        const auto pi = static_cast<std::size_t>(gp.index(x, y, z));
        if (!inside) continue;
        const auto wi = static_cast<std::size_t>(gw.index(static_cast<int>(w[0]), static_cast<int>(w[1]), static_cast<int>(w[2])));
        pflags[pi] = ghost && flags[wi] == 0 ? kGhostFlag : flags[wi];
        prho[pi] = rho[wi];
        for (int a = 0; a < 3; ++a) pu[3 * pi + static_cast<std::size_t>(a)] = u[3 * wi + static_cast<std::size_t>(a)];
      }
}

void place_piece(const Grid& whole, const Grid& piece, int c, const std::vector<double>& part, std::vector<double>& out) {
  const GridView gw = whole.view(), gp = piece.view();
  const auto cc = static_cast<std::size_t>(c);
  if (part.size() != cc * static_cast<std::size_t>(gp.n)) throw Error("place_piece: field size does not match the piece");
  out.resize(cc * static_cast<std::size_t>(gw.n));
  const CellBox o = piece.owned();
  for (int z = 0; z < o.ext[2]; ++z)
    for (int y = 0; y < o.ext[1]; ++y)
      for (int x = 0; x < o.ext[0]; ++x) {
        const auto pi = static_cast<std::size_t>(gp.index(x + o.lo[0], y + o.lo[1], z + o.lo[2]));
        const auto wi = static_cast<std::size_t>(gw.index(static_cast<int>(x + piece.offset[0]),
                                                          static_cast<int>(y + piece.offset[1]),
                                                          static_cast<int>(z + piece.offset[2])));
        for (std::size_t k = 0; k < cc; ++k) out[cc * wi + k] = part[cc * pi + k];
      }
}

}  // namespace lbdem::lbm
