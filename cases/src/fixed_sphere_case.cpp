// The fixed-sphere scene (lattice units): flow through a simple cubic (3D) /
// square (2D) array of fixed spheres/disks driven by a body force, run to a
// steady state detected automatically (imb/fixed_sphere.hpp, through the
// loop of halo/simulation.hpp); drag coefficient against Sangani & Acrivos
// (1982). It takes lattice units (cell size 1, fluid time step 1, fluid
// density 1) and says so (`units: lattice` is required), because the
// validation cases of the first paper are stated that way (Table 1).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <span>
#include <unordered_map>
#include <spdlog/spdlog.h>

#include "imb/fixed_sphere.hpp"
#include "lbm/distributed_fluid.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/stop_poll.hpp"
#include "dem/particle_output.hpp"
#include "cfd/homogeneous_slip.hpp"
#include "dem/packing.hpp"
#include "imb/suspension.hpp"
#include "core/output_section.hpp"
#include "core/units.hpp"
#include "cases/scenes.hpp"
#include "halo/simulation.hpp"
#include "core/json.hpp"
#include "imb/checkpoint.hpp"
#include "scene_checks.hpp"
#include "core/async_writer.hpp"
#include "core/error.hpp"
#include "core/output.hpp"
#include "core/phase_clock.hpp"
#include "core/progress.hpp"
#include "core/signals.hpp"
#include "core/memory_use.hpp"
#include "dem/domain.hpp"
#include "dem/grid_box.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/drag_error.hpp"
#include "imb/fraction_table.hpp"
#include "imb/psm_reader.hpp"
#include "imb/psm_settings.hpp"
#include "lbm/storage_checks.hpp"
#include "lbm/tau.hpp"

namespace lbdem {
namespace {

void require_lattice_units(const Config& root) {
  const std::string u = root.choice("units", {"lattice"});
  (void)u;
}

// ------------------------------------------------------------ fixed sphere
int run_fixed_sphere(const Config& root, const RunOptions& opt) {
  // The drag of a steady state: a run is redone, never continued.
  if (opt.restart)
    throw ConfigError("--restart: scene 'fixed_sphere' does not write checkpoints (it runs to a steady state); run "
                      "it again instead");
  require_lattice_units(root);
  imb::FixedSphereSpec s;
  const Config g = root.section("geometry");
  s.dim = static_cast<int>(g.integer_in("dim", 3, 2, 3));
  s.diameter = g.number_in("diameter", 2.0, 1000.0, "sphere diameter in cells (d/l)");
  s.chi = g.number_in("chi", 0.5, 0.05, 0.75, "d/L, L the array period (Sangani-Acrivos series valid to 0.75)");
  s.offset = g.number_in("offset", 0.0, -0.5, 0.5, "sphere centre offset from the cell-aligned centre, cells");
  s.keys = {g.full_key("dim"), g.full_key("diameter"), g.full_key("chi")};
  g.finish();
  const Config f = root.section("fluid");
  imb::read_fluid_common(f, s);
  s.streaming = f.choice("streaming", "aa", {"aa", "two_lattice"}) == "aa" ? lbm::StreamKind::AA
                                                                          : lbm::StreamKind::TwoLattice;
  s.re_p = f.number_in("re_p", 0.2, 1e-4, 50.0, "target particle Reynolds number (sets the body force)");
  f.finish();
  imb::PsmOptions po;
  po.weight = imb::PsmWeight::NobleTorczynskiWall;  // the default with or without a psm section
  double max_drag_error = imb::kMaxDragErrorBar;
  if (auto ps = root.optional_section("psm")) {
    imb::read_psm(*ps, po, s.slots, max_drag_error);
    ps->finish();
  }
  s.magic = imb::resolve_magic(s.magic, s.diameter, s.tau);
  s.method = po.map.method;
  s.pipeline = po.pipeline;
  s.variant = po.variant;
  s.even_relaxation = po.even_relaxation;
  s.weight = po.weight;
  const Config st = root.section("steady");
  s.tolerance = st.number_in("tolerance", 1e-7, 1e-14, 1e-2, "estimated remaining relative change of the drag");
  s.max_steps = st.integer_in("max_steps", 2000000, 1, std::numeric_limits<long>::max());
  st.finish();
  std::string outdir = read_output(root, 0).directory;
  s.parallel = halo::parse_parallel(root);
  root.accept("scene");
  root.finish();
  if (opt.output) outdir = *opt.output;
  if (opt.steps) s.max_steps = *opt.steps;
  imb::check_fixed_sphere(root, s.dim, s.diameter, s.chi, s.precision, s.streaming, s.max_steps, cases::planned_backend(opt),
                         opt.force, opt.steps ? "--steps" : "steady.max_steps");
  {
    // 16-bit storage (lbm/storage_checks.hpp): the flow is steady, its scale the array period d / chi.
    lbm::LbmSetup fl;
    fl.precision = s.precision;
    fl.tau = s.tau;
    const double nu = lbm::lattice_viscosity(s.tau);
    for (const auto& w : lbm::storage_warnings(fl, s.re_p * nu / s.diameter, s.diameter / s.chi, double(s.max_steps)))
      spdlog::warn("{}: {}", root.source(), w);
  }
  if (halo::Comm::world().root())  // 2D: the 2D map (fixed disks)
    imb::report_expected_drag_error(imb::drag_query(s.diameter, s.tau, s.collision, s.magic, po, s.precision, s.dim),
                                    max_drag_error, opt.validate_only, opt.quiet);
  const auto psm = imb::psm_settings(root, imb::drag_query(s.diameter, s.tau, s.collision, s.magic, po, s.precision, s.dim),
                                imb::to_string(s.pipeline == imb::PsmPipeline::Fused ? imb::PsmPipeline::Fused
                                                                                     : imb::PsmPipeline::Mapped),
                                s.precision, halo::Comm::world().root());
  const Backend backend = resolve_backend(opt.backend);
  const halo::Comm& comm = halo::Comm::world();
  s.comm = &comm;
  if (comm.distributed()) {
    // The cut is checked before anything is allocated or written.
    const long L = std::lround(s.diameter / s.chi);
    halo::decompose(Grid::whole({L, L, s.dim == 3 ? L : 1}), comm.size(), s.parallel.decomposition,
                    "parallel.decomposition");
  }
  if (opt.validate_only) return 0;
  if (comm.root()) io::prepare_output_dir(outdir, opt.overwrite);
  std::unique_ptr<imb::FractionTable> table;
  if (s.method == imb::FractionMethod::Table) {
    table = std::make_unique<imb::FractionTable>(imb::build_fraction_table(s.dim));
    s.table = table.get();
  }
  s.quiet = opt.quiet;
  if (!opt.quiet)
    spdlog::info("scene fixed_sphere: {}D, d/l = {}, chi = {}, tau = {}, {} Lambda = {}, {} fractions, backend {}",
                 s.dim, s.diameter, s.chi, s.tau, to_string(s.collision), s.magic, imb::to_string(s.method),
                 to_string(backend));
  const auto r = imb::run_fixed_sphere(s, backend);
  // Numbers to the last bit (K is compared across rank counts and settings).
  json::Value js = json::Value::object();
  js.set("scene", "fixed_sphere")
      .set("dim", s.dim)
      .set("diameter", s.diameter)
      .set("chi", s.chi)
      .set("tau", s.tau)
      .set("magic", s.magic)
      .set("K", r.K)
      .set("K_reference", r.K_ref)
      .set("relative_error", r.rel_error)
      .set("re_p", r.re_p)
      .set("steps", r.steps)
      .set("converged", r.converged)
      .set("seconds", r.seconds)
      .set("mlups", r.mlups)
      .set("interrupted", r.interrupted)
      .set("ranks", comm.size())
      .set("psm", json::Value::parse(imb::psm_settings_json(psm)));
  if (comm.root()) io::write_text_atomically(outdir + "/summary.json", js.dump());
  if (r.interrupted) {
    spdlog::warn("stopped by {} at step {} before the drag converged; K so far in {}/summary.json", stop_signal_name(),
                 r.steps, outdir);
    return kExitInterrupted;
  }
  if (!opt.quiet) {
    spdlog::info("K = {:.5f} against {} {:.5f}: error {:+.3f}%, Re_p = {:.3f}, {} steps{} in {:.1f} s ({:.1f} MLUPS)",
                 r.K, s.dim == 3 ? "Sangani & Acrivos (1982)" : "Sangani & Acrivos (1982, cylinders)", r.K_ref,
                 100 * r.rel_error, r.re_p, r.steps, r.converged ? "" : " (NOT converged: raise steady.max_steps)",
                 r.seconds, r.mlups);
    spdlog::info("results: {}/summary.json", outdir);
  }
  return r.converged ? 0 : 1;
}

}  // namespace

std::vector<std::string> fixed_sphere_scene_names() { return {"fixed_sphere"}; }

int run_fixed_sphere_case(const Config& root, const RunOptions& opt) { return run_fixed_sphere(root, opt); }

}  // namespace lbdem
