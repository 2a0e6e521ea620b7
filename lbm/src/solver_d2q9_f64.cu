// Instantiation of the LBM solver for D2Q9 with double storage.
#include "solver_impl.hpp"

namespace lbdem::lbm {
std::unique_ptr<LbmSolver> make_solver_d2q9_f64(const LbmSetup& s, Backend b) {
  return std::make_unique<SolverImpl<D2Q9, double>>(s, b);
}
}  // namespace lbdem::lbm
