#include "forces.hpp"

namespace lbdem::dem {
void run_forces_frictional(DemSystem::Impl& m) { force_step<true>(m); }
}  // namespace lbdem::dem
