#pragma once
// One force evaluation on either path; instantiated per friction flag in
// forces_frictionless.cu / forces_frictional.cu.
#include "core/algorithms.hpp"
#include "force_kernels.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

// The particle path's one kernel on `ex` (also what a sub-step graph captures):
// on the device with State::lanes > 1 the lane-parallel kernel.
template <bool Friction>
void force_particle(const Exec& ex, Index n, const State& s) {
#if defined(__CUDACC__)
  if (ex.on_device() && s.lanes > 1) {
    if (n <= 0) return;
    const unsigned grid = static_cast<unsigned>((n * s.lanes + 255) / 256);
    switch (s.lanes) {
      case 2: force_lanes_kernel<Friction, 2><<<grid, 256, 0, ex.stream()>>>(s, n); break;
      case 4: force_lanes_kernel<Friction, 4><<<grid, 256, 0, ex.stream()>>>(s, n); break;
      case 8: force_lanes_kernel<Friction, 8><<<grid, 256, 0, ex.stream()>>>(s, n); break;
      default: force_lanes_kernel<Friction, 16><<<grid, 256, 0, ex.stream()>>>(s, n); break;
    }
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
  }
#endif
  launch(ex, n, ForceParticle<Friction>{s});
}

// The fused sub-step (ForceKickDrift) on `ex`: the particle path's forces of
// the state in k.s and the next kick-drift, positions and predictors into
// the arrays of `out` (the view after the store's swap); on the device with
// State::lanes > 1 the lane-parallel kernel.
template <bool Friction>
void force_kick_drift(const Exec& ex, Index n, const KickDrift<Friction>& k, const State& out) {
  const ForceKickDrift<Friction> fk{k, out.pos, out.vpr, out.wpr};
#if defined(__CUDACC__)
  if (ex.on_device() && k.s.lanes > 1) {
    if (n <= 0) return;
    const unsigned grid = static_cast<unsigned>((n * k.s.lanes + 255) / 256);
    switch (k.s.lanes) {
      case 2: force_lanes_kick_drift_kernel<Friction, 2><<<grid, 256, 0, ex.stream()>>>(fk, n); break;
      case 4: force_lanes_kick_drift_kernel<Friction, 4><<<grid, 256, 0, ex.stream()>>>(fk, n); break;
      case 8: force_lanes_kick_drift_kernel<Friction, 8><<<grid, 256, 0, ex.stream()>>>(fk, n); break;
      default: force_lanes_kick_drift_kernel<Friction, 16><<<grid, 256, 0, ex.stream()>>>(fk, n); break;
    }
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
  }
#endif
  launch(ex, n, fk);
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
