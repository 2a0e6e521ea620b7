// Instantiation of the LBM solver for D3Q19 with 16-bit storage, IEEE half; compute in float.
#include "solver_impl.hpp"

namespace lbdem::lbm {
std::unique_ptr<LbmSolver> make_solver_d3q19_f16s(const LbmSetup& s, Backend b) {
  return std::make_unique<SolverImpl<D3Q19, Fp16s>>(s, b);
}
}  // namespace lbdem::lbm
