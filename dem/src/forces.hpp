#pragma once
// One force evaluation on either path; instantiated per friction flag in
// forces_frictionless.cu / forces_frictional.cu.
#include "core/algorithms.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

template <bool Friction>
void force_step(DemSystem::Impl& m) {
  const State s = m.state();
  if (m.p.path == ForcePath::Particle) {
    launch(m.ex, m.n, ForceParticle<Friction>{s});
    return;
  }
  // Pair path (Yu et al. 2024, Sec. 3): count contacts per particle, prefix
  // sum, fill the compacted pair array, then one thread per pair.
  launch(m.ex, m.n, PairInit<Friction>{s, m.ccount.data()});
  exclusive_scan(m.ex, m.ccount.data(), m.coffs.data(), m.n + 1, m.scratch());
  launch(m.ex, m.n, PairFill{s, m.coffs.data(), m.pairs.data()});
  // The pair count stays on the device: a fixed number of workers strides over it.
  const Index workers = m.n;
  launch(m.ex, workers, PairForce<Friction>{s, m.pairs.data(), m.coffs.data() + m.n, workers});
}

}  // namespace lbdem::dem
