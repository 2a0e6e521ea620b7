#pragma once
// Dispatch of the PSM step kernel: runtime choices -> template parameters.
#include <cstdlib>
#include "core/exec.hpp"
#include "imb/psm_coupling.hpp"

namespace lbdem::imb {

template <class L, class T, lbm::StreamKind S, int P, bool B, bool Force, PsmVariant V>
void psm_launch_f(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                  const SlotForceView& sf, const PsmOptions& opt,
                  const std::array<bool, 3>& periodic) {
  PsmStepKernel<L, T, S, P, B, Force, V> k;
  k.set_lattice(raw, s.tau, opt.weight);
  for (int a = 0; a < 3; ++a) k.periodic[a] = periodic[static_cast<std::size_t>(a)];
  k.slots = slots;
  k.out = sf;
  // Three blocks of 256 per multiprocessor in fp32 (<= 85 registers, like the
  // plain kernel), two in fp64: unbounded, the odd AA step took 109 / 176
  // registers and ran at half the plain kernel's bandwidth.
  for_each_bounded<sizeof(T) == 4 ? 3 : 2>(ex, raw.grid.n, k);
}

template <class L, class T, lbm::StreamKind S, int P, bool B, PsmVariant V>
void psm_launch(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                const SlotForceView& sf, const PsmOptions& opt,
                const std::array<bool, 3>& periodic) {
  const bool force = raw.body_force[0] != 0 || raw.body_force[1] != 0 || raw.body_force[2] != 0;
  if (force) psm_launch_f<L, T, S, P, B, true, V>(ex, s, raw, slots, sf, opt, periodic);
  else psm_launch_f<L, T, S, P, B, false, V>(ex, s, raw, slots, sf, opt, periodic);
}

template <class L, class T, lbm::StreamKind S, int P>
void psm_launch_b(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                  const SlotForceView& sf, const PsmOptions& opt,
                  const std::array<bool, 3>& periodic) {
  if (raw.has_boundaries) {
    if (opt.variant == PsmVariant::NEBB) psm_launch<L, T, S, P, true, PsmVariant::NEBB>(ex, s, raw, slots, sf, opt, periodic);
    else psm_launch<L, T, S, P, true, PsmVariant::Superposition>(ex, s, raw, slots, sf, opt, periodic);
  } else {
    if (opt.variant == PsmVariant::NEBB) psm_launch<L, T, S, P, false, PsmVariant::NEBB>(ex, s, raw, slots, sf, opt, periodic);
    else psm_launch<L, T, S, P, false, PsmVariant::Superposition>(ex, s, raw, slots, sf, opt, periodic);
  }
}

template <class L, class T>
void psm_step_typed(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt,
                    const std::array<bool, 3>& periodic) {
  if (s.streaming == lbm::StreamKind::AA) {
    if ((raw.step & 1) == 0) psm_launch_b<L, T, lbm::StreamKind::AA, 0>(ex, s, raw, slots, sf, opt, periodic);
    else psm_launch_b<L, T, lbm::StreamKind::AA, 1>(ex, s, raw, slots, sf, opt, periodic);
  } else {
    psm_launch_b<L, T, lbm::StreamKind::TwoLattice, 0>(ex, s, raw, slots, sf, opt, periodic);
  }
}

}  // namespace lbdem::imb
