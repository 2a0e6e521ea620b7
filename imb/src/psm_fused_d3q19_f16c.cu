// Fused PSM step kernels for D3Q19 with 16-bit population storage (fp16c,
// core/half.hpp), arithmetic in float: see psm_fused_impl.hpp.
#include "psm_fused_impl.hpp"

namespace lbdem::imb {

void psm_fused_d3q19_f16c(const Exec& ex, const FusedArgs& a) { fused_step_typed<lbm::D3Q19, Fp16c>(ex, a); }

}  // namespace lbdem::imb
