// Mapped-pipeline PSM kernels with 16-bit population storage (fp16s, fp16c;
// D2Q9 and D3Q19), arithmetic in float: see psm_impl.hpp.
#include "psm_impl.hpp"

namespace lbdem::imb {

void psm_step_f16(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                  const SlotForceView& sf, const PsmOptions& opt) {
  const bool c = s.precision == lbm::Precision::FP16C;
  if (s.lattice == lbm::LatticeKind::D2Q9) {
    if (c) psm_step_typed<lbm::D2Q9, Fp16c>(ex, s, raw, slots, sf, opt);
    else psm_step_typed<lbm::D2Q9, Fp16s>(ex, s, raw, slots, sf, opt);
  } else {
    if (c) psm_step_typed<lbm::D3Q19, Fp16c>(ex, s, raw, slots, sf, opt);
    else psm_step_typed<lbm::D3Q19, Fp16s>(ex, s, raw, slots, sf, opt);
  }
}

}  // namespace lbdem::imb
