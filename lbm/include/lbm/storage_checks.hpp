#pragma once
// Where 16-bit population storage (precision fp16s / fp16c) is not good enough,
// as warnings a case checker prints before a run. fp32 and fp64 get none.
//
// Rounding model (tests/lbm/test_fp16_storage.cpp checks it): each step
// rounds every stored population g = f - w to 16 bits, relative error up to
// u16 = 2^-11 (fp16s) or 2^-12 (fp16c) while |g| >= 2^-14 (the smallest
// normal value of both formats), absolute error up to 2^-25 (fp16s) or 2^-26
// (fp16c) below it.
//  * Steady and slowly varying flows: a population stops changing once its
//    change per step falls below half its 16-bit spacing, so the flow stalls
//    short of its steady state. The slowest viscous mode of a scale L changes
//    by a relative 4 pi^2 nu / L^2 per step, which leaves a relative velocity
//    error of about u16 L^2 / (4 pi^2 nu) (tests/lbm/test_fp16_storage.cpp
//    holds a channel of height L to it). tau near 1/2 (small nu) makes it large.
//  * Low Mach number: the velocity part 3 w c.u of the populations of the
//    smallest weight w = 1/36 falls below 2^-14 when |u| < 12 * 2^-14 (about
//    7.3e-4 in lattice units); the velocity is then resolved only to an
//    absolute spacing / (3 w), not to a relative u16.
//  * tau near 1/2: the collision maps a perturbation to (1 - 1/tau) times
//    itself, so the rounding noise of each store is hardly damped.
//  * Long runs: mass is conserved exactly by the collision and the walls but
//    not by the rounding of the stores, in every step where the flow changes.
#include <string>
#include <vector>

#include "lbm/solver.hpp"

namespace lbdem::lbm {

// Unit roundoff of the storage format: 2^-11 (fp16s), 2^-12 (fp16c), 2^-24, 2^-53.
double storage_unit_roundoff(Precision p);

// Estimated relative velocity error of a steady flow of scale `length`
// (cells) at viscosity nu (lattice units): u16 L^2 / (4 pi^2 nu).
double steady_storage_error(Precision p, double length, double nu);

// Warnings for a run with this setup (empty unless the storage is 16-bit).
// u_ref: the reference speed in lattice units (<= 0: unknown, no low-Mach
// check); length: the largest flow scale in cells (e.g. a channel's height,
// a periodic box's side); steps: the planned step count. Each warning names
// the case key `precision` and says what to change.
std::vector<std::string> storage_warnings(const LbmSetup& s, double u_ref, double length, double steps);

}  // namespace lbdem::lbm
