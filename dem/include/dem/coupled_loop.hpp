#pragma once
// The coupled fluid-particle time step, shared by the resolved mode (imb/:
// PSM fluid on the lattice) and the unresolved mode (cfd/: volume-averaged
// gas with drag closures). Each mode supplies its fluid side as a
// FluidCoupling; the order of the step is written once, here:
//
//   1. fluid: the fluid advances one step and leaves every particle's
//      hydrodynamic force and torque in the DEM's coupling input
//      (ParticleView::ext_force / ext_torque, current storage order);
//   2. particles: N DEM sub-steps (contacts, walls, gravity) with that force
//      held constant;
//   3. remap: the fluid side takes the particles' new positions (possibly
//      reordered by a neighbour-list rebuild) for its next step;
//   4. checks that need not run every step (overflow reports, ...).
#include "dem/particle_view.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

class FluidCoupling {
 public:
  virtual ~FluidCoupling() = default;
  virtual void fluid_step(const ParticleView& p) = 0;       // step 1
  virtual void particles_moved(const ParticleView& p) = 0;  // step 3
  virtual void after_step(long /*steps_done*/) {}           // step 4
};

class CoupledLoop {
 public:
  CoupledLoop(DemSystem& dem, FluidCoupling& fluid, int dem_substeps)
      : dem_(dem), fluid_(fluid), substeps_(dem_substeps) {}

  void step() {
    fluid_.fluid_step(dem_.view());       // 1. fluid step, forces into the DEM's coupling input
    dem_.advance(substeps_);              // 2. N DEM sub-steps with the force held
    fluid_.particles_moved(dem_.view());  // 3. remap the particles at their new positions
    ++steps_;
    fluid_.after_step(steps_);            // 4. periodic checks
  }
  long steps() const { return steps_; }
  // Restart from a checkpoint (core/checkpoint.hpp): the steps done before.
  void restore_steps(long steps) { steps_ = steps; }

 private:
  DemSystem& dem_;
  FluidCoupling& fluid_;
  int substeps_;
  long steps_ = 0;
};

}  // namespace lbdem::dem
