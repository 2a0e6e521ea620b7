// PSM kernels for D2Q9 (fp32, fp64) and the per-particle force gather.
#include <cmath>

#include "psm_impl.hpp"

namespace lbdem::imb {

void psm_step_d2q9(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                   const PsmParticles& p, const SlotForceView& sf, const PsmOptions& opt,
                   const std::array<bool, 3>& periodic) {
  if (s.precision == lbm::Precision::FP32) psm_step_typed<lbm::D2Q9, float>(ex, s, raw, slots, p, sf, opt, periodic);
  else psm_step_typed<lbm::D2Q9, double>(ex, s, raw, slots, p, sf, opt, periodic);
}

void psm_gather(const Exec& ex, const lbm::LbmRaw& raw, const CellSlotsView& slots, const SlotForceView& sf,
                const PsmParticles& p, const std::array<bool, 3>& periodic, int dim, const ForceOut& out,
                double max_radius, Buffer<double>& scratch) {
  const int extent = static_cast<int>(std::floor(2.0 * (max_radius + 1.0))) + 2;  // >= cells per box axis
  const Index rows = dim == 3 ? static_cast<Index>(extent) * extent : extent;
  scratch.reserve_discard(ex.backend(), 6 * rows * p.n);  // grows once, never per step
  GatherRows k1{slots, sf, p, raw.grid, {periodic[0], periodic[1], periodic[2]}, dim, extent, scratch.data()};
  for_each(ex, rows * p.n, k1);
  FinishGather k2{p, dim, rows, scratch.data(), out.force, out.torque, out.fstride, out.tstride,
                  {out.per_volume[0], out.per_volume[1], out.per_volume[2]}};
  for_each(ex, p.n, k2);
}

}  // namespace lbdem::imb
