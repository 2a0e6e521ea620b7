#pragma once
// The checkpoint side of the scene drivers (core/checkpoint.hpp): what a
// scene's checkpoint is of, the sections it writes, and the time series a
// restart continues. Each run loop calls these in a few lines.
#include <optional>
#include <string>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/output.hpp"
#include "halo/comm.hpp"
#include "lbm/solver.hpp"

namespace lbdem::dem {
class DemSystem;
}
namespace lbdem::imb {
class CoupledSolver;
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

// A CSV time series at `path` with these columns: a fresh run starts it; a
// restart keeps its rows up to the checkpoint (ckpt::Run::kept_rows, read
// before the file is rewritten) and goes on appending.
io::TimeSeries open_series(const ckpt::Run& run, const std::string& path, const std::vector<std::string>& columns,
                           long interval);

// A run on several ranks: ConfigError for --restart or a checkpoint section
// (not supported yet), and no checkpoint at a stop signal.
void refuse_distributed(const std::optional<std::string>& restart, ckpt::Policy& p, bool distributed);

// The writing rank prepares the output folder (ckpt::Run::prepare_output);
// every rank learns whether it failed and throws (the writer its own error).
// Collective.
void prepare_output_on_writer(ckpt::Run& run, bool writer, const halo::Comm& comm, bool overwrite,
                              const std::string& outdir);

}  // namespace lbdem::cases
