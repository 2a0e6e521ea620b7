// Instantiation of the LBM solver for D3Q19 with float storage.
#include "solver_impl.hpp"

namespace lbdem::lbm {
std::unique_ptr<LbmSolver> make_solver_d3q19_f32(const LbmSetup& s, Backend b) {
  return std::make_unique<SolverImpl<D3Q19, float>>(s, b);
}
}  // namespace lbdem::lbm
