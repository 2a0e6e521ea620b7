#pragma once
// One force evaluation on either path; instantiated per friction flag in
// forces_frictionless.cu / forces_frictional.cu.
#include "core/algorithms.hpp"
#include "force_kernels.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

// The particle path's one kernel on `ex` (also what a sub-step graph captures).
template <bool Friction>
void force_particle(const Exec& ex, Index n, const State& s) {
  launch(ex, n, ForceParticle<Friction>{s});
}

template <bool Friction>
void force_step(DemSystem::Impl& m) {
  const State s = m.state();
  // Rows of the owned particles (ghosts, behind them, are partners only).
  const Index n = m.store.owned();
  if (m.p.path == ForcePath::Particle) {
    force_particle<Friction>(m.ex, n, s);
    return;
  }
  // Pair path (Yu et al. 2024, Sec. 3): count contacts per particle, prefix
  // sum, fill the compacted pair array, then one thread per pair.
  NeighbourList& l = m.lists;
  launch(m.ex, n, PairInit<Friction>{s, l.ccount.data()});
  exclusive_scan(m.ex, l.ccount.data(), l.coffs.data(), n + 1, m.scratch());
  launch(m.ex, n, PairFill{s, l.coffs.data(), l.pairs.data()});
  // The pair count stays on the device: a fixed number of workers strides over it.
  const Index workers = n;
  launch(m.ex, workers, PairForce<Friction>{s, l.pairs.data(), l.coffs.data() + n, workers});
}

}  // namespace lbdem::dem
