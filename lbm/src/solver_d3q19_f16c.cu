// Instantiation of the LBM solver for D3Q19 with 16-bit storage, 1-4-11 (core/half.hpp); compute in float.
#include "solver_impl.hpp"

namespace lbdem::lbm {
std::unique_ptr<LbmSolver> make_solver_d3q19_f16c(const LbmSetup& s, Backend b) {
  return std::make_unique<SolverImpl<D3Q19, Fp16c>>(s, b);
}
}  // namespace lbdem::lbm
