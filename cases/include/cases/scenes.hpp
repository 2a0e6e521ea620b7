#pragma once
// Scene drivers behind `lbdem run CASE.yaml`. The case file's top-level key
// `scene` names the scene; each module family registers its scenes here.
#include <optional>
#include <string>
#include <vector>

#include "core/config.hpp"

namespace lbdem {

// Command-line overrides; they win over the case file.
struct RunOptions {
  std::string backend = "auto";     // cuda | cpu | auto
  std::optional<long> steps;        // overrides the case's step count
  std::optional<std::string> output;  // overrides output.directory
  bool overwrite = false;           // replace an earlier run's files (io::prepare_output_dir)
  bool quiet = false;               // no progress lines (tests)
  bool validate_only = false;       // parse and check everything, then return 0 before any output
  bool force = false;               // start a run planned to take longer than a year (cases/src/scene_checks.hpp)
  std::optional<std::string> restart;  // checkpoint file to continue from (core/checkpoint.hpp; main resolves --restart)
};

// Each family: the scene names it knows and its runner (returns an exit code:
// 0, or kExitInterrupted (core/signals.hpp) when a stop signal ended the time
// loop after its final output; throws lbdem::Error subclasses on bad input or
// divergence).
std::vector<std::string> lbm_scene_names();
int run_lbm_case(const Config& root, const RunOptions& opt);
std::vector<std::string> dem_scene_names();
int run_dem_case(const Config& root, const RunOptions& opt);
std::vector<std::string> fixed_sphere_scene_names();
int run_fixed_sphere_case(const Config& root, const RunOptions& opt);
std::vector<std::string> particles_scene_names();
int run_particles_case(const Config& root, const RunOptions& opt);
std::vector<std::string> cfd_scene_names();
int run_cfd_case(const Config& root, const RunOptions& opt);

// Looks up `scene` and runs it; unknown scene -> ConfigError with a suggestion.
int run_case(const Config& root, const RunOptions& opt);
std::vector<std::string> all_scene_names();

}  // namespace lbdem
