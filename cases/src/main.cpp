// The `lbdem` command.
//   lbdem run CASE.yaml [--backend cuda|cpu|auto] [--steps N] [--output DIR] [--overwrite] [--force] [--quiet]
//                      [--restart RUN_DIR|CHECKPOINT]
//   lbdem check CASE.yaml      validate a case file without running it
//   lbdem info                 build, backends, devices
// Exit codes: 0 ok, 2 invalid input, 3 diverged, 4 resources (memory, disk full),
// 5 stopped by SIGINT/SIGTERM (final output written, summary.json says
// "interrupted": true; a second signal ends the process at once), 1 other error.
#include <omp.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "cases/scenes.hpp"
#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "core/signals.hpp"
#include "halo/comm.hpp"
#include "halo/device.hpp"
#include "halo/transport.hpp"

using namespace lbdem;

namespace {
// On several ranks an error ends every rank: rank 0 prints it (a bad case file
// fails alike on every rank), any other rank prints only errors of its own;
// then the run is aborted with the exit code. On one rank: print and return.
int fail(int code, const char* what, bool every_rank_alike) {
  const halo::Comm& comm = halo::Comm::world();
  if (comm.root() || !every_rank_alike) std::fprintf(stderr, "error: %s\n", what);
  std::fflush(stderr);
  // Rank 0's abort ends every rank; the others give it time to print first.
  if (comm.distributed() && !comm.root() && every_rank_alike) std::this_thread::sleep_for(std::chrono::seconds(3));
  if (comm.distributed()) comm.abort(code);
  return code;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lbdem: lattice Boltzmann + DEM engine for particle-resolved gas-solid flow"};
  app.require_subcommand(1);
  RunOptions opt;
  std::string case_file;
  long steps = -1;
  std::string output;

  auto* run = app.add_subcommand("run", "run a case file");
  run->add_option("case", case_file, "case file (YAML)")->required();
  run->add_option("--backend", opt.backend, "cuda, cpu or auto (default auto)")
      ->check(CLI::IsMember({"cuda", "cpu", "auto", "host", "gpu"}));
  run->add_option("--steps", steps, "number of steps (overrides the case file)")->check(CLI::Range(1L, 1000000000000L));
  auto* output_opt = run->add_option("--output", output, "output folder (overrides output.directory)");
  run->add_flag("--overwrite", opt.overwrite,
                "replace an earlier run's results in the output folder (removes only the files its .lbdem_manifest "
                "names; refuses if the folder holds anything else)");
  run->add_flag("--force", opt.force,
                "start a run even when it is planned to take more than a year of wall time at the fastest speed this "
                "code reaches");
  run->add_flag("--quiet", opt.quiet, "no progress lines");
  std::string restart;
  auto* restart_opt = run->add_option(
      "--restart", restart,
      "continue the run whose checkpoint is in this run folder (or this checkpoint file), bit for bit, in that folder");

  auto* check = app.add_subcommand("check", "validate a case file without running it");
  check->add_option("case", case_file, "case file (YAML)")->required();
  check->add_flag("--force", opt.force, "accept a run planned to take more than a year (as run --force)");

  auto* info = app.add_subcommand("info", "build, backends and devices");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  spdlog::set_pattern("[%H:%M:%S] %v");

  try {
    if (*info) {
      if (!halo::Comm::world().root()) return 0;  // under mpirun: one report
      std::printf("lbdem %s\n", LBDEM_VERSION);
      std::printf("backends: cpu (OpenMP, %d threads)%s\n", omp_get_max_threads(),
                  cuda_compiled() ? ", cuda (compiled in)" : " (built without CUDA)");
      const std::string why = cuda_unavailable_reason();
      if (why.empty()) {
        for (auto& d : cuda_device_descriptions()) std::printf("device %s\n", d.c_str());
      } else {
        std::printf("cuda: %s\n", why.c_str());
      }
      const halo::Comm& comm = halo::Comm::world();
      std::printf("ranks: %s; transports: host_mpi%s%s\n", comm.describe().c_str(),
                  halo::mpi_cuda_aware() ? ", device_mpi" : "", halo::nccl_compiled() ? ", nccl" : "");
      std::printf("scenes:");
      for (auto& s : all_scene_names()) std::printf(" %s", s.c_str());
      std::printf("\n");
      return 0;
    }
    // An empty --output "" (an unset shell variable, say) is a mistake, not a
    // request for the case file's folder.
    if (output_opt->count() > 0 && output.empty())
      throw ConfigError("--output was given an empty folder name; give a folder, or leave --output out to use the case "
                        "file's output.directory");
    const Config cfg = Config::load_file(case_file);
    if (steps > 0) opt.steps = steps;
    if (output_opt->count() > 0) opt.output = output;
    if (restart_opt->count() > 0) {
      // The run goes on in the checkpoint's folder (--output, if given, must name it).
      opt.restart = ckpt::resolve(restart);
      if (!opt.output) opt.output = std::filesystem::path(*opt.restart).parent_path().string();
      if (opt.output->empty()) opt.output = ".";
      const std::string scene = cfg.text("scene");
      const auto fluid = lbm_scene_names();
      if (scene != "particles" && scene != "dem" && std::find(fluid.begin(), fluid.end(), scene) == fluid.end())
        throw ConfigError("--restart: scene '" + scene + "' does not write checkpoints; scenes that do: particles, "
                          "dem and the fluid scenes");
    }
    if (*check) {
      // Parse and check everything (keys, ranges, units, memory), then stop
      // before the output folder is touched.
      opt.quiet = true;
      opt.validate_only = true;
      run_case(cfg, opt);
      std::printf("%s: scene '%s' ok\n", case_file.c_str(), cfg.text("scene").c_str());
      return 0;
    }
    // Under mpirun every rank runs the case on its piece; the GPU of a rank
    // is picked from its rank on the node. Only rank 0 logs progress.
    const halo::Comm& comm = halo::Comm::world();
    if (!comm.root()) spdlog::set_level(spdlog::level::warn);
    if (resolve_backend(opt.backend) == Backend::Cuda) halo::select_device(comm);
    install_stop_handlers();
    return run_case(cfg, opt);
  } catch (const ConfigError& e) {
    return fail(2, e.what(), true);
  } catch (const DivergenceError& e) {
    return fail(3, e.what(), true);
  } catch (const ResourceError& e) {
    return fail(4, e.what(), false);
  } catch (const std::exception& e) {
    return fail(1, e.what(), false);
  }
}
