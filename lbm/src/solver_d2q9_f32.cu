// Instantiation of the LBM solver for D2Q9 with float storage.
#include "solver_impl.hpp"

namespace lbdem::lbm {
std::unique_ptr<LbmSolver> make_solver_d2q9_f32(const LbmSetup& s, Backend b) {
  return std::make_unique<SolverImpl<D2Q9, float>>(s, b);
}
}  // namespace lbdem::lbm
