#pragma once
// The unresolved mode's side of the shared coupled step (dem/coupled_loop.hpp):
// the gas step leaves every particle's set I force (drag plus -V_p grad p) in
// the DEM's coupling input; the DEM then runs its sub-steps with that force
// held. The gas fraction is deposited at the start of each gas step from the
// positions the particles have then, so nothing is needed when they move.
#include "cfd/gas_solver.hpp"
#include "dem/coupled_loop.hpp"

namespace lbdem::cfd {

class GasDemCoupling : public dem::FluidCoupling {
 public:
  explicit GasDemCoupling(GasSolver& gas) : gas_(gas) {}
  void fluid_step(const dem::ParticleView& p) override { gas_.step(p); }
  void particles_moved(const dem::ParticleView&) override {}
  GasSolver& gas() { return gas_; }

 private:
  GasSolver& gas_;
};

}  // namespace lbdem::cfd
