#pragma once
// Dispatch of the PSM step kernel: runtime choices -> template parameters.
#include "core/exec.hpp"
#include "imb/psm_coupling.hpp"
#include "lbm/dispatch.hpp"

namespace lbdem::imb {

template <class L, class T, lbm::StreamKind S, int P, bool B, bool Force, PsmVariant V>
void psm_launch(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                const SlotForceView& sf, const PsmOptions& opt) {
  PsmStepKernel<L, T, S, P, B, Force, V> k;
  k.set_lattice(raw, s.tau, opt.weight, opt.body_force_on_solid, opt.even_relaxation);
  k.slots = slots;
  k.out = sf;
  // Three blocks of 256 per multiprocessor when computing in fp32 (<= 85
  // registers, like the plain kernel; 16-bit storage too), two in fp64:
  // without the bound the compiler gives the odd A-A step more registers than
  // that and fewer blocks fit.
  for_each_cell_bounded<sizeof(lbm::compute_t<T>) == 4 ? 3 : 2>(ex, raw.grid, raw.owned, k);
}

template <class L, class T>
void psm_step_typed(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt) {
  lbm::dispatch_step(s.streaming, raw.step, raw.has_boundaries, lbm::has_body_force(raw.body_force),
                     [&](auto S, auto P, auto B, auto F) {
                       dispatch_variant(opt.variant, [&](auto V) {
                         psm_launch<L, T, decltype(S)::value, decltype(P)::value, decltype(B)::value,
                                    decltype(F)::value, decltype(V)::value>(ex, s, raw, slots, sf, opt);
                       });
                     });
}

}  // namespace lbdem::imb
