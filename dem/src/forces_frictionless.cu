#include "forces.hpp"

namespace lbdem::dem {
void run_forces_frictionless(DemSystem::Impl& m) { force_step<false>(m); }
void launch_force_particle_frictionless(const Exec& ex, Index n, const State& s) { force_particle<false>(ex, n, s); }
void launch_force_kick_drift_frictionless(const Exec& ex, Index n, const State& s, const State& out, const KickArgs& a) {
  force_kick_drift<false>(ex, n, KickDrift<false>{s, a.synced, a.extrap, a.rec, a.next, a.report, a.check}, out);
}
}  // namespace lbdem::dem
