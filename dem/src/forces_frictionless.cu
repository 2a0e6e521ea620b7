#include "forces.hpp"

namespace lbdem::dem {
void run_forces_frictionless(DemSystem::Impl& m) { force_step<false>(m); }
void launch_force_particle_frictionless(const Exec& ex, Index n, const State& s) { force_particle<false>(ex, n, s); }
}  // namespace lbdem::dem
