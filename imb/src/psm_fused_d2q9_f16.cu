// Fused PSM step kernels for D2Q9 with 16-bit population storage (fp16s,
// fp16c), arithmetic in float: see psm_fused_impl.hpp.
#include "psm_fused_impl.hpp"

namespace lbdem::imb {

void psm_fused_d2q9_f16(const Exec& ex, const FusedArgs& a) {
  if (a.setup->precision == lbm::Precision::FP16C) fused_step_typed<lbm::D2Q9, Fp16c>(ex, a);
  else fused_step_typed<lbm::D2Q9, Fp16s>(ex, a);
}

}  // namespace lbdem::imb
