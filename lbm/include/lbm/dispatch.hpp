#pragma once
// Runtime -> template dispatch of a stream-collide step, written once for every
// kernel that streams the populations (the plain LBM step, the PSM steps of imb/):
// the streaming scheme and the A-A parity of the next step, boundaries on/off,
// forcing on/off. Each becomes a std::integral_constant argument of the callback,
// so the callee writes `decltype(S)::value` where it needs the template value.
#include <type_traits>

#include "lbm/kernels.hpp"

namespace lbdem::lbm {

template <StreamKind S>
using StreamConstant = std::integral_constant<StreamKind, S>;
template <int P>
using ParityConstant = std::integral_constant<int, P>;

// Calls fn(StreamConstant<S>, ParityConstant<P>) for the scheme and the parity
// of the step that follows `steps_done` steps (A-A alternates its even and odd
// step; the two-lattice scheme has one step, parity 0).
template <class Fn>
void dispatch_parity(StreamKind streaming, long steps_done, Fn&& fn) {
  if (streaming == StreamKind::AA) {
    if ((steps_done & 1) == 0) fn(StreamConstant<StreamKind::AA>{}, ParityConstant<0>{});
    else fn(StreamConstant<StreamKind::AA>{}, ParityConstant<1>{});
  } else {
    fn(StreamConstant<StreamKind::TwoLattice>{}, ParityConstant<0>{});
  }
}

// Calls fn(StreamConstant<S>, ParityConstant<P>, std::bool_constant<Bnd>,
// std::bool_constant<Force>): the step's scheme and parity as above, with
// boundary handling and the body force compiled in only where present.
template <class Fn>
void dispatch_step(StreamKind streaming, long steps_done, bool has_boundaries, bool has_force, Fn&& fn) {
  dispatch_parity(streaming, steps_done, [&](auto S, auto P) {
    if (has_boundaries) {
      if (has_force) fn(S, P, std::true_type{}, std::true_type{});
      else fn(S, P, std::true_type{}, std::false_type{});
    } else {
      if (has_force) fn(S, P, std::false_type{}, std::true_type{});
      else fn(S, P, std::false_type{}, std::false_type{});
    }
  });
}

// True if the body force has a non-zero component (the forcing terms are then compiled in).
template <class Array>
inline bool has_body_force(const Array& F) {
  return F[0] != 0 || F[1] != 0 || F[2] != 0;
}

}  // namespace lbdem::lbm
