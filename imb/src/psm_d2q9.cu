// PSM kernels for D2Q9 (fp32, fp64) and the per-particle force gather.
#include <cmath>

#include "psm_impl.hpp"

namespace lbdem::imb {

void psm_step_d2q9(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                   const SlotForceView& sf, const PsmOptions& opt) {
  if (s.precision == lbm::Precision::FP32) psm_step_typed<lbm::D2Q9, float>(ex, s, raw, slots, sf, opt);
  else psm_step_typed<lbm::D2Q9, double>(ex, s, raw, slots, sf, opt);
}

void psm_gather(const Exec& ex, const CellSlotsView& slots, const SlotForceView& sf, const PairView& pairs,
                const PsmParticles& p, int dim, const ForceOut& out) {
  GatherPairs k{p, slots, sf, pairs, dim,
                ForceWriter{p, dim, out.force, out.torque, out.fstride, out.tstride,
                            {out.per_volume[0], out.per_volume[1], out.per_volume[2]}, out.per_volume_count}};
  for_each(ex, 32 * p.n, k);  // one warp per particle (block size a multiple of 32)
}

}  // namespace lbdem::imb
