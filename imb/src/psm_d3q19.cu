// PSM kernels for D3Q19 (fp32, fp64).
#include "psm_impl.hpp"

namespace lbdem::imb {

void psm_step_d3q19(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt) {
  if (s.precision == lbm::Precision::FP32) psm_step_typed<lbm::D3Q19, float>(ex, s, raw, slots, sf, opt);
  else psm_step_typed<lbm::D3Q19, double>(ex, s, raw, slots, sf, opt);
}

}  // namespace lbdem::imb
