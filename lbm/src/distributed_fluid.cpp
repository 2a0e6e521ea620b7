#include "lbm/distributed_fluid.hpp"

#include <algorithm>
#include <cstring>

#include "core/error.hpp"
#include "rest_state.hpp"

namespace lbdem::lbm {

namespace {
halo::Decomposition choose(const LbmSetup& whole, const halo::ParallelOptions& po, int ranks) {
  return halo::decompose(whole.domain, ranks, po.decomposition, "parallel.decomposition");
}
}  // namespace

std::size_t distributed_fluid_memory(const LbmSetup& whole, const halo::ParallelOptions& po, int ranks) {
  if (ranks <= 1) return lbm_memory_estimate(whole);
  const halo::Decomposition dec = choose(whole, po, ranks);
  std::size_t most = 0;
  for (int r = 0; r < ranks; ++r) {
    LbmSetup s = whole;
    s.domain = dec.piece(whole.domain, r);
    most = std::max(most, lbm_memory_estimate(s));
  }
  return most;
}

DistributedFluid::DistributedFluid(const LbmSetup& whole, Backend backend, const halo::ParallelOptions& po,
                                   const halo::Comm& comm)
    : comm_(comm), whole_(whole) {
  if (!comm.distributed()) {
    dec_.global = whole.domain.global;
    dec_.periodic = whole.domain.periodic;
    solver_ = make_lbm_solver(whole, backend);
    return;
  }
  dec_ = choose(whole, po, comm.size());
  LbmSetup s = whole;
  s.domain = dec_.piece(whole.domain, comm.rank());
  solver_ = make_lbm_solver(s, backend);
  transport_ = halo::make_transport(po.transport, comm, backend);
  halo_ = std::make_unique<FluidHalo>(*solver_, dec_, comm.rank(), *transport_);
}

void DistributedFluid::initialize(const std::vector<std::uint8_t>& flags, const std::vector<double>& rho,
                                  const std::vector<double>& u) {
  if (!halo_) {
    solver_->initialize(flags, rho, u);
    return;
  }
  std::vector<std::uint8_t> pf;
  std::vector<double> pr, pu;
  piece_fields(whole_.domain, solver_->setup().domain, flags, rho, u, pf, pr, pu);
  solver_->initialize(pf, pr, pu);
  halo_->fill();
}

void DistributedFluid::initialize_uniform(const std::function<std::uint8_t(long, long, long)>& flag, double rho) {
  // The rules of piece_fields (lbm/halo_exchange.hpp) for this rank's storage
  // cells: images on split axes (wrapped where periodic), a ghost whose image
  // is fluid is kGhostFlag, one beyond a walled end kGhostFlag at rest.
  const Grid& whole = whole_.domain;
  const Grid& piece = solver_->setup().domain;
  const GridView gp = piece.view();
  const auto n = static_cast<std::size_t>(gp.n);
  std::vector<std::uint8_t> pf(n, halo_ ? kGhostFlag : 0);
  // Layers in parallel (hundreds of millions of cells on a GPU's piece):
  // `flag` is called from several threads at once.
#pragma omp parallel for schedule(static)
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
        if (!inside) continue;  // kGhostFlag at rest (rho 1 as piece_fields leaves it)
        const std::uint8_t f = flag(w[0], w[1], w[2]);
        pf[static_cast<std::size_t>(gp.index(x, y, z))] = ghost && f == 0 ? kGhostFlag : f;
      }
  // piece_fields leaves the ghost layers beyond a walled end at density 1:
  // on a split closed axis, the layer below a piece that starts the grid and
  // the layer above one that ends it.
  std::vector<CellBox> unit;
  for (int a = 0; halo_ && a < 3; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    const int gw = piece.ghost_on(a);
    if (gw == 0 || whole.periodic[ua]) continue;
    CellBox b;
    b.ext[0] = gp.nx;
    b.ext[1] = gp.ny;
    b.ext[2] = gp.nz;
    b.ext[a] = gw;
    if (piece.offset[ua] == 0) unit.push_back(b);
    if (piece.offset[ua] + piece.local[ua] == whole.global[ua]) {
      b.lo[a] = gw + static_cast<int>(piece.local[ua]);
      unit.push_back(b);
    }
  }
  // Density and velocity made on the device (no host copy of either field).
  initialize_at_rest(*solver_, pf, rho, unit);
  if (halo_) halo_->fill();
}

void DistributedFluid::step(long n) {
  if (halo_) halo_->step(n);
  else solver_->step(n);
}

LbmDiagnostics DistributedFluid::diagnostics() {
  LbmDiagnostics d = solver_->diagnostics();
  if (!halo_) {
    max_speed_rank_ = 0;
    nonfinite_rank_ = d.finite ? -1 : 0;
    return d;
  }
  const Grid& p = solver_->setup().domain;
  auto to_global = [&](std::array<long, 3>& c) {
    if (c[0] < 0) return;
    for (int a = 0; a < 3; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      c[ua] += p.offset[ua] - p.ghost_on(a);
    }
  };
  to_global(d.max_speed_cell);
  to_global(d.nonfinite_cell);
  // Deviation of the mass from the fluid cell count is what a sum must keep
  // (the count is exact): sum (mass - cells) and add the global count.
  std::vector<double> sums{d.mass - static_cast<double>(d.fluid_cells), d.momentum[0], d.momentum[1], d.momentum[2]};
  comm_.sum(sums);
  const long cells = comm_.sum(d.fluid_cells);
  LbmDiagnostics g;
  g.fluid_cells = cells;
  g.mass = static_cast<double>(cells) + sums[0];
  g.momentum = {sums[1], sums[2], sums[3]};
  const auto [vmax, who] = comm_.maxloc(d.max_speed);
  g.max_speed = vmax;
  max_speed_rank_ = who;
  nonfinite_rank_ = -1;
  // The owner of the extreme tells everyone where it is.
  std::vector<std::byte> cell(sizeof(long) * 3);
  if (comm_.rank() == who) std::memcpy(cell.data(), d.max_speed_cell.data(), cell.size());
  comm_.broadcast(cell, who);
  std::memcpy(g.max_speed_cell.data(), cell.data(), cell.size());
  g.finite = comm_.all(d.finite);
  if (!g.finite) {
    // The lowest rank with a non-finite cell names it.
    const long bad = d.finite ? comm_.size() : comm_.rank();
    const long first = -comm_.max(-bad);
    std::vector<std::byte> nc(sizeof(long) * 3);
    if (comm_.rank() == first) std::memcpy(nc.data(), d.nonfinite_cell.data(), nc.size());
    comm_.broadcast(nc, static_cast<int>(first));
    std::memcpy(g.nonfinite_cell.data(), nc.data(), nc.size());
    nonfinite_rank_ = static_cast<int>(first);
  }
  return g;
}

void DistributedFluid::macroscopic(std::vector<double>& rho, std::vector<double>& u) {
  if (!halo_) {
    solver_->macroscopic(rho, u);
    return;
  }
  std::vector<double> pr, pu;
  solver_->macroscopic(pr, pu);
  // Owned cells only, x-fastest, density then velocity.
  const Grid& p = solver_->setup().domain;
  const GridView gv = p.view();
  const CellBox o = p.owned();
  std::vector<double> mine;
  mine.reserve(static_cast<std::size_t>(o.size()) * 4);
  for (int z = 0; z < o.ext[2]; ++z)
    for (int y = 0; y < o.ext[1]; ++y)
      for (int x = 0; x < o.ext[0]; ++x) {
        const auto i = static_cast<std::size_t>(gv.index(x + o.lo[0], y + o.lo[1], z + o.lo[2]));
        mine.push_back(pr[i]);
        for (std::size_t k = 0; k < 3; ++k) mine.push_back(pu[3 * i + k]);
      }
  // Cells no rank owns (wall layers): density 1, velocity 0.
  const std::vector<double> all = gather_owned(mine, 4, {1.0, 0.0, 0.0, 0.0});
  rho.clear();
  u.clear();
  if (!comm_.root()) return;
  const std::size_t n = all.size() / 4;
  rho.resize(n);
  u.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    rho[i] = all[4 * i];
    for (std::size_t c = 0; c < 3; ++c) u[3 * i + c] = all[4 * i + 1 + c];
  }
}

std::vector<double> DistributedFluid::gather_owned(const std::vector<double>& mine, int comps,
                                                   const std::vector<double>& fill) {
  const auto nc = static_cast<std::size_t>(comps);
  if (!halo_) return mine;
  const auto all = comm_.gather(std::as_bytes(std::span<const double>(mine)), 0);
  if (!comm_.root()) return {};
  const GridView gw = whole_.domain.view();
  std::vector<double> out(nc * static_cast<std::size_t>(gw.n), 0.0);
  if (!fill.empty())
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = fill[i % nc];
  for (int r = 0; r < comm_.size(); ++r) {
    const Grid q = dec_.piece(whole_.domain, r);
    const CellBox qo = q.owned();
    const auto& bytes = all[static_cast<std::size_t>(r)];
    if (bytes.size() != static_cast<std::size_t>(qo.size()) * nc * sizeof(double))
      throw Error("gathering a field: rank " + std::to_string(r) + " sent a piece of the wrong size");
    const auto* v = reinterpret_cast<const double*>(bytes.data());
    std::size_t k = 0;
    for (int z = 0; z < qo.ext[2]; ++z)
      for (int y = 0; y < qo.ext[1]; ++y)
        for (int x = 0; x < qo.ext[0]; ++x) {
          const auto wi = static_cast<std::size_t>(gw.index(static_cast<int>(x + q.offset[0]), static_cast<int>(y + q.offset[1]),
                                                            static_cast<int>(z + q.offset[2])));
          for (std::size_t c = 0; c < nc; ++c) out[nc * wi + c] = v[k++];
        }
  }
  return out;
}

std::vector<io::PieceBox> DistributedFluid::piece_boxes() const {
  std::vector<io::PieceBox> out(static_cast<std::size_t>(comm_.size()));
  for (int r = 0; r < comm_.size(); ++r) {
    const Grid q = halo_ ? dec_.piece(whole_.domain, r) : whole_.domain;
    out[static_cast<std::size_t>(r)] = {q.offset, q.local};
  }
  return out;
}

std::size_t DistributedFluid::memory_bytes() const {
  const auto mine = static_cast<long>(solver_->memory_bytes());
  return static_cast<std::size_t>(comm_.sum(mine));
}

std::string DistributedFluid::describe() const {
  if (!halo_) return "1 rank";
  return dec_.describe() + " ranks, halo by " + halo::to_string(transport_->kind());
}

}  // namespace lbdem::lbm
