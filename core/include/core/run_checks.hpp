#pragma once
// Checks every scene runs while its case file is parsed (before any output
// folder, grid or particle array is made): grids too small to mean anything,
// memory estimated from the sizes in the file (ResourceError, exit code 4),
// and the planned run (longer than a year of wall time even at the fastest
// speed this code reaches needs --force). Each module checks its own state
// with these (lbm/fluid_checks.hpp, dem/particle_checks.hpp,
// imb/coupled_memory.hpp); messages name the key as the user wrote it.
#include <limits>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/exec.hpp"
#include "core/memory_use.hpp"
#include "core/vec.hpp"

namespace lbdem {

namespace checks {
// A number in a message: 4 significant digits, no "-0".
std::string num(double v);
// "[a, b, c]" of the first `dim` components.
std::string vec(const Vec3d& v, int dim);
std::string mib(double bytes);
const char* axis_name(int a);
}  // namespace checks

// ----------------------------------------------------------------- grids
// The fewest fluid cells along an axis for which a scene means something:
// `what` says why (e.g. "a lid-driven cavity needs at least 4 cells per axis
// to hold its vortex").
void check_min_cells(const Config& root, const std::string& key, const std::vector<long>& cells, long min_cells,
                     const std::string& what);

// ----------------------------------------------------------------- memory
// The table `lbdem check` prints: one line per component (bytes per cell and
// total), then the total.
std::string memory_table(const MemoryUse& m, double cells);
// Refuses (ResourceError) when `device_bytes` exceed the backend's free memory
// or `host_bytes` (plus device_bytes on the host backend) the host's. `key`
// names what sets the size, `fix` the way out.
void check_memory(const Config& root, Backend b, double device_bytes, double host_bytes, const std::string& key,
                  const std::string& what, const std::string& fix);

// A memory size as a user writes it: a number with an optional unit, K/M/G/T
// (or KiB/MiB/GiB/TiB) in powers of 1024, KB/MB/GB/TB in powers of 1000, B or
// none for bytes.
// (--memory; ConfigError naming it otherwise)
std::size_t parse_memory_size(const std::string& text);

// ----------------------------------------------------------------- the plan
// Fastest rates this code reaches on one GPU of the largest kind (H100/H200),
// and the least wall time of one step (kernel launches): a planned run that
// needs more than a year even at these rates is refused without --force.
constexpr double kFastestCellUpdatesPerSecond = 1e10;
constexpr double kFastestParticleStepsPerSecond = 2e9;
constexpr double kLeastSecondsPerStep = 1e-6;
constexpr double kMaxPlannedSeconds = 365.25 * 24 * 3600;
// `force`: --force (no refusal for the wall time). `steps`: planned steps, `cell_updates` / `particle_steps` per step,
// `steps_key` the key(s) that set the step count.
void check_plan(const Config& root, bool force, double steps, double cell_updates, double particle_steps,
                const std::string& steps_key);
// A step count computed in double (end time over dt) as a long, saturated at
// the largest long instead of overflowing; check_plan refuses such a plan.
inline long saturating_steps(double steps) {
  return steps < 9.2e18 ? static_cast<long>(steps) : std::numeric_limits<long>::max();
}

}  // namespace lbdem
