#include "forces.hpp"

namespace lbdem::dem {
void run_forces_frictionless(DemSystem::Impl& m) { force_step<false>(m); }
}  // namespace lbdem::dem
