#pragma once
// The fluid at rest made by a solver on its own backend (lbm/src only): what
// DistributedFluid::initialize_uniform needs, without host copies of the
// grid's density and velocity.
#include <cstdint>
#include <vector>

#include "core/grid.hpp"
#include "lbm/solver.hpp"

namespace lbdem::lbm {

// Implemented by the solvers of lbm/src (SolverImpl).
class RestStateInit {
 public:
  virtual ~RestStateInit() = default;
  virtual void initialize_at_rest(const std::vector<std::uint8_t>& flags, double rho,
                                  const std::vector<CellBox>& unit_density) = 0;
};

// The state s.initialize(flags, rho, u) makes (bit for bit) from density
// `rho` and velocity zero in every storage cell but those of `unit_density`
// (boxes in storage coordinates), which get density 1. A solver of lbm/src
// makes the fields on its backend slab by slab; another gets them as host
// vectors through initialize().
void initialize_at_rest(LbmSolver& s, const std::vector<std::uint8_t>& flags, double rho,
                        const std::vector<CellBox>& unit_density);

}  // namespace lbdem::lbm
