// Fused PSM step kernels for D3Q19 in double (one translation unit per precision so
// the heavy instantiations build in parallel): see psm_fused_impl.hpp.
#include "psm_fused_impl.hpp"

namespace lbdem::imb {

void psm_fused_d3q19_f64(const Exec& ex, const FusedArgs& a) { fused_step_typed<lbm::D3Q19, double>(ex, a); }

}  // namespace lbdem::imb
