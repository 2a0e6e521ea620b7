#include "forces.hpp"

namespace lbdem::dem {
void run_forces_frictional(DemSystem::Impl& m) { force_step<true>(m); }
void launch_force_particle_frictional(const Exec& ex, Index n, const State& s) { force_particle<true>(ex, n, s); }
void launch_force_kick_drift_frictional(const Exec& ex, Index n, const State& s, const State& out, const KickArgs& a) {
  force_kick_drift<true>(ex, n, KickDrift<true>{s, a.synced, a.extrap, a.rec, a.next, a.report, a.check}, out);
}
}  // namespace lbdem::dem
