#pragma once
// The checkpoint side of the scene drivers (core/checkpoint.hpp): what a
// scene's checkpoint is of, the sections it writes, and the time series a
// restart continues. Each run loop calls these in a few lines.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/grid.hpp"
#include "core/output.hpp"
#include "halo/comm.hpp"
#include "lbm/solver.hpp"

namespace lbdem::dem {
class DemSystem;
}
namespace lbdem::imb {
class CoupledSolver;
}
namespace lbdem::cfd {
class GasSolver;
}

namespace lbdem::cases {

// Identity of a scene on a fluid grid: scene, lattice, precision, streaming,
// collision, grid extent and periodicity.
ckpt::Identity fluid_identity(const std::string& scene, const lbm::LbmSetup& s);

// A scene's own values a restart needs (reference values of its series, ...)
// travel in the "run" section beside the modules' state.
using RunValues = std::vector<double>;

// Sections of the coupled particles scene: run, lbm, dem, coupling.
void save_coupled(ckpt::Writer& w, lbm::LbmSolver& fluid, const dem::DemSystem& dem, const imb::CoupledSolver& cs,
                  const RunValues& values);
RunValues load_coupled(ckpt::Reader& r, lbm::LbmSolver& fluid, dem::DemSystem& dem, imb::CoupledSolver& cs);
// Sections of a fluid scene: run, lbm.
void save_fluid(ckpt::Writer& w, lbm::LbmSolver& fluid, const RunValues& values);
RunValues load_fluid(ckpt::Reader& r, lbm::LbmSolver& fluid);
// Sections of the dem scene: run, dem.
void save_dem(ckpt::Writer& w, const dem::DemSystem& dem, const RunValues& values);
RunValues load_dem(ckpt::Reader& r, dem::DemSystem& dem);
// Sections of the fluidized_bed scene (one rank): run, gas, dem.
void save_bed(ckpt::Writer& w, const cfd::GasSolver& gas, const dem::DemSystem& dem, const RunValues& values);
RunValues load_bed(ckpt::Reader& r, cfd::GasSolver& gas, dem::DemSystem& dem);

// A CSV time series at `path` with these columns: a fresh run starts it; a
// restart keeps its rows up to the checkpoint (ckpt::Run::kept_rows, read
// before the file is rewritten) and goes on appending.
io::TimeSeries open_series(const ckpt::Run& run, const std::string& path, const std::vector<std::string>& columns,
                           long interval);

// ---------------------------------------------------------------------------
// Several ranks. One file all the same (core/checkpoint.hpp), written by rank
// 0; the other ranks stream their sections to it through MPI in rank order,
// a few MiB at a time. The header's layout lines name the rank count and the
// cut; a restart on any rank count and cut reads it (rank 0 reads the file).
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
//
// Particles: section "dem.<k>" (chunked) holds rank k's DemSystem::save_state.
// The same rank count and cut: each rank loads its own (bit for bit). Any
// other: rank 0 turns every section into portable particle records
// (DemSystem::saved_particles) and broadcasts them; each rank keeps those in
// its piece and rebuilds (DemSystem::restore_particles; to round-off, bitwise
// where contacts are summed in global-id order).
//
// A one-rank run writes and reads the one-rank sections above unchanged.
// ---------------------------------------------------------------------------

// The layout lines of a checkpoint written on `ranks` ranks cut as `dims`.
ckpt::Identity rank_layout(int ranks, const std::string& dims);

// Opens the checkpoint side of a run on every rank (collective): rank 0
// reads and checks a restart's checkpoint (when it refuses, every rank
// throws ConfigError, rank 0 with the reason); the others follow its step.
ckpt::Run open_run(const std::string& outdir, const ckpt::Policy& policy, const ckpt::Identity& id,
                   const std::optional<std::string>& restart, const halo::Comm& comm);

// One checkpoint written by every rank of `comm` (collective; every rank
// makes the same calls in the same order). Write errors on rank 0 are
// reported by commit() on every rank, after the others have sent their part.
class SharedWriter {
 public:
  SharedWriter(ckpt::Run& run, const halo::Comm& comm, long step, double time);
  ~SharedWriter();
  SharedWriter(const SharedWriter&) = delete;
  SharedWriter& operator=(const SharedWriter&) = delete;
  // Section `name`, written by rank 0 alone (fill is called there only).
  template <class Fill>
  void root_section(const std::string& name, Fill&& fill) {
    if (!comm_.root()) return;
    begin(name);
    fill(sink());
  }
  // Sections "<name>.0", "<name>.1", ...: fill(sink) on every rank, for its
  // own. `chunked`: each section's data as chunks (u64 length, bytes) ended
  // by a zero length, so that a reader can pass a section on without
  // parsing it (ChunkSource reads it).
  template <class Fill>
  void rank_sections(const std::string& name, Fill&& fill, bool chunked = false) {
    if (comm_.root()) {
      begin(name + ".0");
      fill(chunked ? chunk_sink() : sink());
      if (chunked) close_chunks();
      for (int k = 1; k < comm_.size(); ++k) receive(name + "." + std::to_string(k), k, chunked);
    } else {
      ckpt::Sink& out = forward();
      fill(out);
      close_forward();
    }
  }
  void commit();

 private:
  void begin(const std::string& name);
  ckpt::Sink& sink();
  ckpt::Sink& chunk_sink();
  void close_chunks();
  void receive(const std::string& name, int rank, bool chunked);
  ckpt::Sink& forward();
  void close_forward();
  struct State;
  ckpt::Run& run_;
  const halo::Comm& comm_;
  long step_;
  std::unique_ptr<State> st_;
};

// Sections of a fluid scene written by every rank: the raw one-rank path on
// one rank, else "run" and the canonical pieces. Collective.
void save_fluid(ckpt::Run& run, const halo::Comm& comm, long step, double time, lbm::LbmSolver& fluid,
                const RunValues& values);
// The canonical piece of `fluid` (section "lbm.<rank>").
void save_fluid_piece(ckpt::Sink& out, lbm::LbmSolver& fluid);
// Loads a fluid scene's checkpoint on every rank (collective), however many
// ranks wrote it. `whole`: the whole grid; `flags`: its cell flags, compared
// with the checkpoint's (empty: not compared). The run values on every rank.
RunValues load_fluid(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                     const std::vector<std::uint8_t>& flags);
// Sections of the dem scene on every rank: the raw one-rank path on one
// rank; else "run" and each rank's DemSystem::save_state ("dem.<k>",
// chunked). Collective.
void save_dem(ckpt::Run& run, const halo::Comm& comm, long step, double time, const dem::DemSystem& dem,
              const RunValues& values);
// Loads the dem scene's checkpoint on every rank (collective): the same
// rank count and decomposition `dims` (halo::Decomposition::describe) load
// each rank's raw section (bit for bit); any other reads the particles of
// every section and hands each rank those in its piece
// (DemSystem::restore_particles, to round-off).
RunValues load_dem(ckpt::Run& run, const halo::Comm& comm, dem::DemSystem& dem, const std::string& dims);
void load_dem_shared(ckpt::Run& run, const halo::Comm& comm, dem::DemSystem& dem, const std::string& dims);
// The coupled particles scene on every rank: "run", the fluid pieces, the
// DEM sections, "coupling". Collective.
void save_coupled(ckpt::Run& run, const halo::Comm& comm, long step, double time, lbm::LbmSolver& fluid,
                  const dem::DemSystem& dem, const imb::CoupledSolver& cs, const RunValues& values);
RunValues load_coupled(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags, dem::DemSystem& dem, imb::CoupledSolver& cs,
                       const std::string& dims);

// The "run" section (rank 0 reads it), on every rank. Collective.
RunValues load_run_shared(ckpt::Run& run, const halo::Comm& comm);
// Rank 0 reads the fluid sections (pieces or a one-rank raw section) and
// every rank keeps its cells. Collective.
void load_fluid_shared(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags);

// The writing rank prepares the output folder (ckpt::Run::prepare_output);
// every rank learns whether it failed and throws (the writer its own error).
// Collective.
void prepare_output_on_writer(ckpt::Run& run, bool writer, const halo::Comm& comm, bool overwrite,
                              const std::string& outdir);

}  // namespace lbdem::cases
