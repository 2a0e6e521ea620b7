#pragma once
// Around the coupled step of a run on any number of ranks: the particles'
// domain, cut where the grid is cut, refused before anything is allocated when
// the coupling cannot run on it; and the run's timing summary.
#include <array>
#include <string>
#include <vector>

#include "core/json.hpp"
#include "dem/domain.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "halo/parallel_options.hpp"
#include "imb/coupled.hpp"
#include "lbm/distributed_fluid.hpp"

namespace lbdem::imb {

// The particles of a run on several ranks, cut where the grid is cut
// (imb/coupled.hpp): refuses (naming the case file `source` and the grid's
// size by keys.cells), before anything is allocated, a cut the coupling cannot
// run on. A piece must be at least the DEM's ghost width
// 2 r_max + skin thick, and the ghosts, kept within 2 r + skin of a piece at
// each list build and moving at most skin / 2 before the next, must reach
// every particle whose solid fraction can touch a cell of the piece or its
// ghost layer: a cell within r + sqrt(dim) / 2 of the centre (plus the
// linear fractions' radius correction, at most 0.1 r), the ghost layer one
// cell beyond the piece. So r + skin / 2 >= 0.1 r + sqrt(dim) / 2 + 1.
dem::DemDomain coupled_domain(const std::string& source, const lbm::LbmSetup& fluid, int dim, const dem::DemParams& dp,
                               const std::vector<double>& radii, const halo::ParallelOptions& parallel,
                               const halo::Comm& comm, const CoupledKeys& keys = {});

// summary.json "timing": per phase of the coupled step the total seconds of
// each rank, as the max and the mean over the ranks (CoupledSolver
// phase clock; exposed_communication: host time waiting in the fluid halo's
// transport, part of fluid_psm), the set-up phases alike, the snapshot
// output's share, and the particles per rank at the worst series row.
// Collective.
void timing_json(json::Value& js, CoupledSolver& cs, lbm::DistributedFluid& dfluid, const halo::Comm& comm,
                 const std::array<double, 4>& setup, double loop_secs, double output_secs, long snapshots,
                 double ppr_max, double ppr_mean, long ppr_step);

}  // namespace lbdem::imb
