#pragma once
// The fluid's checkpoint: the one-rank raw section (LbmSolver::save_state)
// and, on several ranks, canonical pieces re-sliced on a restart onto any
// rank count and cut (halo/shared_checkpoint.hpp writes and reads the file
// collectively).
//
// Fluid, stored canonically: section "lbm.<k>" holds rank k's owned box
// (global offset and extent), the step count and, per population slot q, the
// stored values of its owned cells (x fastest), then its ghost copies of
// boundary cells. After a whole step the owned slots of all pieces together
// are the one-rank storage (LbmSolver::read_slot says why), with one
// exception: a fluid cell stores its reflections in the neighbouring boundary
// cell's slot (lbm/kernels.hpp), which across a cut is the writer's ghost
// copy; so slot q of a boundary cell is taken from the piece that owns the
// fluid cell that writes it. Rank 0 reads the pieces (or a one-rank
// checkpoint's raw "lbm" section) and broadcasts them in slabs of a few MiB;
// each rank keeps the cells its storage holds (owned cells, ghost copies of
// fluid cells, the boundary slots its own fluid cells read), so no halo fill
// is needed afterwards (A-A at either parity, two-lattice alike) and the
// restart is bit for bit on any cut. Each rank holds a host copy of its own
// piece's populations while loading.
#include <cstdint>
#include <string>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/grid.hpp"
#include "halo/shared_checkpoint.hpp"
#include "lbm/solver.hpp"

namespace lbdem::lbm {

using halo::RunValues;

// Identity of a scene on a fluid grid: scene, lattice, precision, streaming,
// collision, grid extent and periodicity.
ckpt::Identity fluid_identity(const std::string& scene, const LbmSetup& s);

// Sections of a fluid scene on one rank: run, lbm.
void save_fluid(ckpt::Writer& w, LbmSolver& fluid, const RunValues& values);
RunValues load_fluid(ckpt::Reader& r, LbmSolver& fluid);

// Sections of a fluid scene written by every rank: the raw one-rank path on
// one rank, else "run" and the canonical pieces. Collective.
void save_fluid(ckpt::Run& run, const halo::Comm& comm, long step, double time, LbmSolver& fluid,
                const RunValues& values);
// The canonical piece of `fluid` (section "lbm.<rank>").
void save_fluid_piece(ckpt::Sink& out, LbmSolver& fluid);
// Loads a fluid scene's checkpoint on every rank (collective), however many
// ranks wrote it. `whole`: the whole grid; `flags`: its cell flags, compared
// with the checkpoint's (empty: not compared). The run values on every rank.
RunValues load_fluid(ckpt::Run& run, const halo::Comm& comm, LbmSolver& fluid, const Grid& whole,
                     const std::vector<std::uint8_t>& flags);
// Rank 0 reads the fluid sections (pieces or a one-rank raw section) and
// every rank keeps its cells. Collective.
void load_fluid_shared(ckpt::Run& run, const halo::Comm& comm, LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags);

}  // namespace lbdem::lbm
