// Fused PSM step kernels for D3Q19 in float (one translation unit per precision so
// the heavy instantiations build in parallel): see psm_fused_impl.hpp.
#include "psm_fused_impl.hpp"

namespace lbdem::imb {

void psm_fused_d3q19_f32(const Exec& ex, const FusedArgs& a) { fused_step_typed<lbm::D3Q19, float>(ex, a); }

}  // namespace lbdem::imb
