// Instantiation of the LBM solver for D2Q9 with 16-bit storage, IEEE half; compute in float.
#include "solver_impl.hpp"

namespace lbdem::lbm {
std::unique_ptr<LbmSolver> make_solver_d2q9_f16s(const LbmSetup& s, Backend b) {
  return std::make_unique<SolverImpl<D2Q9, Fp16s>>(s, b);
}
}  // namespace lbdem::lbm
