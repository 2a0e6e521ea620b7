#include "imb/psm_coupling.hpp"

namespace lbdem::imb {

void psm_step_d2q9(const Exec&, const lbm::LbmSetup&, const lbm::LbmRaw&, const CellSlotsView&, const SlotForceView&,
                   const PsmOptions&, const std::array<bool, 3>&);
void psm_step_d3q19(const Exec&, const lbm::LbmSetup&, const lbm::LbmRaw&, const CellSlotsView&, const SlotForceView&,
                    const PsmOptions&, const std::array<bool, 3>&);

void psm_fluid_step(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt, const std::array<bool, 3>& periodic) {
  if (s.lattice == lbm::LatticeKind::D2Q9) psm_step_d2q9(ex, s, raw, slots, sf, opt, periodic);
  else psm_step_d3q19(ex, s, raw, slots, sf, opt, periodic);
}

PsmCoupling::PsmCoupling(lbm::LbmSolver& solver, int K, std::array<bool, 3> periodic)
    : solver_(solver), periodic_(periodic), ex_(solver.backend()) {
  if (K < 1) throw ConfigError("PSM slots per cell K = " + std::to_string(K) + ": must be >= 1");
  const lbm::GridView g = lbm::make_grid_view(solver.setup().domain);
  GridShape shape;
  shape.nx = g.nx;
  shape.ny = g.ny;
  shape.nz = g.nz;
  shape.periodic = periodic;
  slots_ = std::make_unique<CellSlots>(solver.backend(), shape, K);
  slot_forces_ = Buffer<double>(solver.backend(), SlotForceView::kComponents * static_cast<Index>(K) * g.n);
}

PsmCoupling::~PsmCoupling() = default;

void PsmCoupling::map(const PsmParticles& p, const PsmOptions& opt, bool check_overflow) {
  if (p.n == 0) return;
  slots_->map(ex_, p, opt.map);
  if (check_overflow) slots_->throw_if_overflow();
}

void PsmCoupling::step(const PsmParticles& p, const PsmOptions& opt, const ForceOut& out) {
  if (p.n == 0) {  // no particles: the plain LBM kernel, no solid field read
    solver_.step(1);
    return;
  }
  const lbm::LbmRaw raw = solver_.raw();
  const SlotForceView sf{slot_forces_.data(), raw.grid.n, slots_->K()};
  psm_fluid_step(ex_, solver_.setup(), raw, slots_->view(), sf, opt, periodic_);
  solver_.commit_external_step();
  if (!out.force) return;  // forces not wanted this step (e.g. a fixed particle between checks)
  const int dim = solver_.setup().lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  psm_gather(ex_, slots_->view(), sf, slots_->pairs(), p, dim, out);
}

}  // namespace lbdem::imb
