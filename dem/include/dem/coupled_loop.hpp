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
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

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
      : dem_(dem), fluid_(fluid), substeps_(dem_substeps) {
    const char* env = std::getenv("LBDEM_STEP_PHASES");
    timed_ = env && std::strcmp(env, "1") == 0;
  }
  // With LBDEM_STEP_PHASES=1 (a diagnostic: it adds a device synchronisation
  // after each phase), the wall time of the fluid steps and of the DEM
  // sub-steps summed over the loop's steps, written to stderr at the end.
  ~CoupledLoop() {
    if (timed_ && timed_steps_ > 0)
      std::fprintf(stderr, "step phases: %ld steps, fluid %.6g s, particles %.6g s (%.4g and %.4g ms per step)\n",
                   timed_steps_, fluid_s_, particles_s_, 1e3 * fluid_s_ / timed_steps_,
                   1e3 * particles_s_ / timed_steps_);
  }

  void step() {
    if (timed_) {
      timed_step();
      return;
    }
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
  // step() with a synchronisation and a clock reading after the fluid step
  // and after the sub-steps (the same launches in the same order otherwise).
  void timed_step() {
    using Clock = std::chrono::steady_clock;
    dem_.synchronize();
    const Clock::time_point t0 = Clock::now();
    fluid_.fluid_step(dem_.view());
    dem_.synchronize();
    const Clock::time_point t1 = Clock::now();
    dem_.advance(substeps_);
    fluid_.particles_moved(dem_.view());
    dem_.synchronize();
    const Clock::time_point t2 = Clock::now();
    fluid_s_ += std::chrono::duration<double>(t1 - t0).count();
    particles_s_ += std::chrono::duration<double>(t2 - t1).count();
    ++timed_steps_;
    ++steps_;
    fluid_.after_step(steps_);
  }

  DemSystem& dem_;
  FluidCoupling& fluid_;
  int substeps_;
  long steps_ = 0;
  bool timed_ = false;
  long timed_steps_ = 0;
  double fluid_s_ = 0, particles_s_ = 0;
};

}  // namespace lbdem::dem
