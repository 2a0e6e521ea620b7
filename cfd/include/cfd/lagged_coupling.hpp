#pragma once
// The bed's coupled step with the particle forces lagged by one gas step
// (case key gas.force_coupling: lagged), so that the gas step and the DEM
// sub-steps run at the same time on the GPU.
//
// Sequential (dem::CoupledLoop, the default): gas step n takes the particles
// at t_n and leaves the forces F_n; the sub-steps t_n -> t_n+1 then use F_n.
// The two halves depend on each other and run one after the other.
//
// Lagged: gas step n takes a copy of the particles at t_n (positions,
// radii, velocities) and computes F_n into a buffer of its own, on a second
// queue, while the sub-steps t_n -> t_n+1 run with F_n-1 (the forces in the
// DEM's coupling input). Then F_n goes to the particles by id (a neighbour
// list rebuild during the sub-steps may have reordered them) and becomes the
// coupling input of the next step. The gas's momentum exchange is unchanged
// (it deposits the drag of the particles it sees); what the particles feel
// lags by one gas step, an explicit coupling error of order gas.dt over the
// particles' response time. A run's first step has no F_-1 and runs
// sequentially; a restart carries F_n-1 in the DEM's coupling input of its
// checkpoint, so a chained run equals a straight one.
//
// On the host the two queues are one: the same arithmetic in the same order.
#include <cstdint>

#include "cfd/gas_solver.hpp"
#include "core/buffer.hpp"
#include "core/exec.hpp"
#include "dem/system.hpp"

namespace lbdem::cfd {

class LaggedCoupling {
 public:
  // `gas` runs on lanes.edge(main), `dem` on `main`; ids of the particles lie
  // in [0, id_limit) (ConfigError naming gas.force_coupling otherwise).
  LaggedCoupling(const Exec& main, const Lanes& lanes, dem::DemSystem& dem, GasSolver& gas, int substeps,
                 std::int64_t id_limit);
  // One coupled step; `first`: no forces of an earlier gas step exist (the
  // first step of a fresh run), so the step runs sequentially.
  void step(bool first);

 private:
  const Exec& main_;
  const Lanes& lanes_;
  dem::DemSystem& dem_;
  GasSolver& gas_;
  int substeps_;
  Index n_;
  // The gas step's copy of the particles, their ids and the forces it computes;
  // the storage index of each id after the sub-steps.
  Buffer<dem::Real4> pos_, vel_, force_;
  Buffer<std::int64_t> id_;
  Buffer<int> slot_;
};

}  // namespace lbdem::cfd
