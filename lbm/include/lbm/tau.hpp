#pragma once
// The relaxation time's rules for the BGK and TRT operators (lbm/collision.hpp),
// written once for every scene.
#include "lbm/collision.hpp"

namespace lbdem::lbm {

// Lattice kinematic viscosity, nu = cs^2 (tau - 1/2) with cs^2 = 1/3 (the
// even-moment relaxation tau+ sets the shear viscosity, BGK and TRT alike).
inline double lattice_viscosity(double tau) { return (tau - 0.5) / 3.0; }

// BGK's stability floor: below tau = 0.51 its single rate leaves the ghost
// moments unstable; TRT (tau- set by the magic parameter) stays stable there.
inline bool bgk_too_close_to_half(CollisionKind k, double tau) { return k == CollisionKind::BGK && tau < 0.51; }

}  // namespace lbdem::lbm
