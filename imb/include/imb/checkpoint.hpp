#pragma once
// The coupled particles scene's checkpoint: "run", the fluid's sections
// (lbm/checkpoint.hpp), the particles' (dem/checkpoint.hpp) and "coupling"
// (CoupledSolver::save_state), on one rank or every rank.
#include <cstdint>
#include <string>
#include <vector>

#include "dem/checkpoint.hpp"
#include "lbm/checkpoint.hpp"

namespace lbdem::imb {

class CoupledSolver;
using halo::RunValues;

// Sections of the coupled particles scene on one rank: run, lbm, dem, coupling.
void save_coupled(ckpt::Writer& w, lbm::LbmSolver& fluid, const dem::DemSystem& dem, const CoupledSolver& cs,
                  const RunValues& values);
RunValues load_coupled(ckpt::Reader& r, lbm::LbmSolver& fluid, dem::DemSystem& dem, CoupledSolver& cs);
// The coupled particles scene on every rank: "run", the fluid pieces, the
// DEM sections, "coupling". Collective.
void save_coupled(ckpt::Run& run, const halo::Comm& comm, long step, double time, lbm::LbmSolver& fluid,
                  const dem::DemSystem& dem, const CoupledSolver& cs, const RunValues& values);
RunValues load_coupled(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags, dem::DemSystem& dem, CoupledSolver& cs,
                       const std::string& dims);

}  // namespace lbdem::imb
