// Fused PSM step kernels for D2Q9 (fp32, fp64): see psm_fused_impl.hpp.
#include "psm_fused_impl.hpp"

namespace lbdem::imb {

void psm_fused_d2q9(const Exec& ex, const FusedArgs& a) {
  if (a.setup->precision == lbm::Precision::FP32) fused_step_typed<lbm::D2Q9, float>(ex, a);
  else fused_step_typed<lbm::D2Q9, double>(ex, a);
}

}  // namespace lbdem::imb
