// Checks of a fluid grid (lbm/fluid_checks.hpp).
#include "lbm/fluid_checks.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/memory_use.hpp"
#include "core/run_checks.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/parallel_options.hpp"

namespace lbdem::lbm {

using checks::num;

void check_fluid_mach(const Config& root, const MachInput& in) {
  if (!(in.dx > 0 && in.nu > 0 && in.u_ref > 0)) return;
  double dt = in.dt;
  if (!(dt > 0)) {
    if (!(in.tau > 0.5)) return;
    dt = (in.tau - 0.5) / 3.0 * in.dx * in.dx / in.nu;
  }
  const double tau = 0.5 + 3.0 * in.nu * dt / (in.dx * in.dx);
  if (!(tau > 0.5)) return;
  const double ma = std::sqrt(3.0) * in.u_ref * dt / in.dx;
  if (!(ma > in.max_mach)) return;
  const double f = in.max_mach / ma;  // every way out scales the lattice speed by this
  const double dt_ok = dt * f;
  const double tau_ok = 0.5 + 3.0 * in.nu * dt_ok / (in.dx * in.dx);
  // With tau kept, dt ~ dx^2 and the lattice speed u dt / dx ~ dx.
  const double dx_ok = in.dx * f;
  std::string msg = root.source() + ": lattice Mach number " + num(ma) + " exceeds the limit " + num(in.max_mach) +
                    " (" + in.max_mach_key + "): the reference speed " + num(in.u_ref) + " m/s, set by '" +
                    in.speed_key + "'" + (in.speed_what.empty() ? "" : " (" + in.speed_what + ")") +
                    ", moves " + num(in.u_ref * dt / in.dx) + " cells per step (dt = " + num(dt) + " s, tau = " +
                    num(tau) + ", dx = " + num(in.dx) + " m); the weakly compressible LBM is inaccurate and unstable "
                    "there. Any one of: lower '" + in.speed_key + "' to at most " +
                    num(in.speed_scale > 0 ? in.u_ref * f / in.speed_scale : in.u_ref * f) +
                    "; a smaller time step: collision.tau <= " + num(tau_ok) + " (or time.dt <= " + num(dt_ok) +
                    " s); a finer grid: domain.spacing <= " + num(dx_ok) +
                    " m with the same tau (more cells for the same size)";
  if (tau_ok < 0.51) msg += "; tau this close to 1/2 needs collision.model: trt";
  throw ConfigError(msg);
}

double lbm_grid_bytes(const LbmSetup& s, double cells) {
  const double tsize = storage_bytes(s.precision);
  const double lattices = s.streaming == StreamKind::AA ? 1 : 2;
  // As lbm_memory: populations, one flag byte, the output staging (rho + u of one slab).
  return cells * (lattice_q(s.lattice) * tsize * lattices + 1) +
         4.0 * sizeof(double) * std::min(cells, static_cast<double>(kOutputSlabCells));
}

LbmSetup rank_fluid(const Config& root, const LbmSetup& whole) {
  const int ranks = halo::Comm::world().size();
  if (ranks <= 1) return whole;
  const halo::ParallelOptions po = halo::parse_parallel(root);
  const halo::Decomposition dec = halo::decompose(whole.domain, ranks, po.decomposition, "parallel.decomposition");
  LbmSetup largest = whole;
  Index most = -1;
  for (int r = 0; r < ranks; ++r) {
    const Grid p = dec.piece(whole.domain, r);
    if (p.storage_cells() > most) {
      most = p.storage_cells();
      largest.domain = p;
    }
  }
  return largest;
}

double rank_grid_bytes(const Config& root, const LbmSetup& fluid) {
  const LbmSetup mine = rank_fluid(root, fluid);
  return lbm_grid_bytes(mine, static_cast<double>(mine.domain.storage_cells()));
}
std::string or_fp32(const LbmSetup& fluid) {
  return fluid.precision == Precision::FP64 ? ", or precision: fp32" : "";
}

}  // namespace lbdem::lbm
