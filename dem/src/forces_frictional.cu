#include "forces.hpp"

namespace lbdem::dem {
void run_forces_frictional(DemSystem::Impl& m) { force_step<true>(m); }
void launch_force_particle_frictional(const Exec& ex, Index n, const State& s) { force_particle<true>(ex, n, s); }
}  // namespace lbdem::dem
