// The `lbdem` command.
//   lbdem run CASE.yaml [--backend cuda|cpu|auto] [--steps N] [--output DIR] [--overwrite] [--force] [--quiet]
//                      [--memory SIZE] [--restart RUN_DIR|CHECKPOINT]
//   lbdem check CASE.yaml [--memory SIZE] [--output DIR] [--overwrite] [--force]
//                              validate a case file without running it: what
//                              run would refuse, the output folder included
//                              (read only) (SIZE: check the memory against a
//                              machine with that much free memory, device and
//                              host, e.g. 80GiB, whatever is free here)
//   lbdem info                 build, backends, devices
//   lbdem compare A.h5 B.h5 [--tolerance T]  compare two snapshots' fields
//   lbdem join RUN_DIR [--step N | --all]   join a run's snapshot pieces into
//                              whole files (core/piece_output.hpp); default: the last step
// Exit codes: 0 ok, 2 invalid input, 3 diverged, 4 resources (memory, disk full),
// 5 stopped by SIGINT/SIGTERM (final output written, summary.json says
// "interrupted": true; a second signal a second or more later ends the process
// at once), 1 other error (compare: the fields differ).
#include <omp.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "cases/scenes.hpp"
#include "core/buffer.hpp"
#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "core/output.hpp"
#include "core/piece_output.hpp"
#include "core/run_checks.hpp"
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
  std::string output, memory;

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
  run->add_option("--memory", memory,
                  "use at most this much memory (device and host), e.g. 40GiB: the memory checks refuse a case that "
                  "needs more");
  std::string restart;
  auto* restart_opt = run->add_option(
      "--restart", restart,
      "continue the run whose checkpoint is in this run folder (or this checkpoint file), bit for bit, in that folder");

  auto* check = app.add_subcommand("check", "validate a case file without running it");
  check->add_option("case", case_file, "case file (YAML)")->required();
  check->add_flag("--force", opt.force, "accept a run planned to take more than a year (as run --force)");
  check->add_flag("--overwrite", opt.overwrite,
                  "accept an output folder holding an earlier run's results (as run --overwrite)");
  auto* check_output_opt =
      check->add_option("--output", output, "output folder to check (overrides output.directory, as run --output)");
  check->add_option("--memory", memory,
                    "check the memory against a machine with this much free memory (device and host), e.g. 80GiB "
                    "for a case meant for another machine");

  auto* info = app.add_subcommand("info", "build, backends and devices");

  auto* join = app.add_subcommand("join", "join a run's per-rank snapshot pieces into whole-grid files");
  std::string join_dir;
  long join_step = -1;
  bool join_all = false;
  join->add_option("run_dir", join_dir, "the run's output folder")->required();
  auto* join_step_opt = join->add_option("--step", join_step, "the step to join (default: the last one)");
  join->add_flag("--all", join_all, "join every step")->excludes(join_step_opt);

  auto* compare = app.add_subcommand("compare", "compare the fields of two whole-grid snapshot files");
  std::string cmp_a, cmp_b;
  double cmp_tol = 0;
  compare->add_option("a", cmp_a, "a snapshot file (.h5; `lbdem join` makes one of a run's pieces)")->required();
  compare->add_option("b", cmp_b, "the snapshot to compare it with")->required();
  compare->add_option("--tolerance", cmp_tol, "largest accepted difference relative to each field's largest "
                                              "magnitude (default 0: bit for bit)")->check(CLI::NonNegativeNumber);

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
      std::printf("precisions (bytes per stored population): fp64 (8), fp32 (4), fp16s (2), fp16c (2)\n");
      std::printf("scenes:");
      for (auto& s : all_scene_names()) std::printf(" %s", s.c_str());
      std::printf("\n");
      return 0;
    }
    if (*compare) {  // exit 0: every dataset within the tolerance; 1: one differs
      if (!halo::Comm::world().root()) return 0;
      bool same = true;
      for (const io::DatasetDiff& d : io::compare_datasets(cmp_a, cmp_b)) {
        const double rel = d.scale > 0 ? d.max_abs / d.scale : d.max_abs;
        same = same && (d.bitwise || rel <= cmp_tol);
        std::printf("%s: %zu values, %s, max |a - b| %.3e, relative to max |a| %.3e\n", d.name.c_str(), d.values,
                    d.bitwise ? "bitwise equal" : "not bitwise", d.max_abs, rel);
      }
      std::printf("%s\n", same ? "same within the tolerance" : "differ beyond the tolerance");
      return same ? 0 : 1;
    }
    if (*join) {
      if (!halo::Comm::world().root()) return 0;  // under mpirun: one process joins
      // Fields and particles; each step one piece in memory at a time. A step
      // written uncut (one rank) is whole already and only indexed.
      std::size_t joined = 0;
      for (const char* prefix : {"fields", "particles"}) {
        const std::vector<long> have = io::piece_steps(join_dir, prefix);
        std::vector<long> todo;
        if (join_all) {
          todo = have;
        } else if (join_step_opt->count() > 0) {
          char t[32];
          std::snprintf(t, sizeof t, "%08ld", join_step);
          if (std::find(have.begin(), have.end(), join_step) != have.end() ||
              std::filesystem::exists(join_dir + "/" + prefix + "_" + t + ".h5"))
            todo = {join_step};
        } else if (!have.empty()) {
          todo = {have.back()};
        }
        for (long st : todo) {
          std::printf("%s\n", io::join_step(join_dir, prefix, st).c_str());
          ++joined;
        }
      }
      if (joined == 0 && join_step_opt->count() > 0)
        throw ConfigError("join: --step " + std::to_string(join_step) + ": no snapshot of that step in '" + join_dir +
                          "' (its .lbdem_manifest names none)");
      if (joined == 0)
        std::printf("%s: no snapshot pieces to join (a run on one rank writes whole files)\n", join_dir.c_str());
      return 0;
    }
    // An empty --output "" (an unset shell variable, say) is a mistake, not a
    // request for the case file's folder.
    if ((output_opt->count() > 0 || check_output_opt->count() > 0) && output.empty())
      throw ConfigError("--output was given an empty folder name; give a folder, or leave --output out to use the case "
                        "file's output.directory");
    // run: use at most SIZE; check: answer for a machine with SIZE free.
    if (!memory.empty()) {
      if (*check) set_memory_assumed(parse_memory_size(memory));
      else set_memory_limit(parse_memory_size(memory));
    }
    const Config cfg = Config::load_file(case_file);
    if (steps > 0) opt.steps = steps;
    if (output_opt->count() > 0 || check_output_opt->count() > 0) opt.output = output;
    if (restart_opt->count() > 0) {
      // The run goes on in the checkpoint's folder (--output, if given, must name it).
      opt.restart = ckpt::resolve(restart);
      if (!opt.output) opt.output = std::filesystem::path(*opt.restart).parent_path().string();
      if (opt.output->empty()) opt.output = ".";
    }
    if (*check) {
      // Parse and check everything (keys, ranges, units, memory), then stop
      // before the output folder is touched.
      opt.quiet = true;
      opt.validate_only = true;
      run_case(cfg, opt);
      // The output folder as run would take it (read only: nothing is created).
      std::string outdir = opt.output.value_or("");
      if (!opt.output) {
        const auto o = cfg.optional_section("output");
        outdir = o && o->has("directory") ? o->text("directory") : "runs/" + cfg.text("scene");
      }
      io::check_output_dir(outdir, opt.overwrite);
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
