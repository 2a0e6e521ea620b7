#pragma once
// The readers of a resolved (PSM) scene's sections, shared by the scenes that
// run the PSM (fixed_sphere, particles): the fluid section's tau, collision
// (with Lambda, `magic: auto` by d/l and tau) and precision, the `psm`
// section, and what the start of a run tells about them (the expected drag
// error, imb/drag_error.hpp; the resolved settings, imb/psm_settings.hpp).
// Messages name the key as written (Config::fail).
#include <string>

#include "core/config.hpp"
#include "imb/drag_error.hpp"
#include "imb/psm.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/psm_settings.hpp"
#include "lbm/solver.hpp"
#include "lbm/tau.hpp"

namespace lbdem::imb {

// fluid.magic: auto (the default) marks Lambda for the resolution rule
// (psm_magic_auto, set once the particle diameter is known).
constexpr double kMagicAuto = -1.0;
// psm.max_expected_drag_error when not given: the half Table 1 bar at the scene's d/l
// (3D; in 2D, where no bar is published, no limit: the estimate is told, not warned about).
constexpr double kMaxDragErrorBar = -1.0;

// fluid.collision (default `def`) and fluid.magic (Lambda, or kMagicAuto).
lbm::CollisionKind read_collision(const Config& f, double& magic, const std::string& def = "trt");
// Lambda of a PSM scene with particles of diameter d (cells) at tau: auto resolved.
double resolve_magic(double magic, double d, double tau);

// tau, collision (with Lambda) and precision of a resolved scene's fluid
// section (FixedSphereSpec and LbmSetup name these fields alike).
template <class S>
void read_fluid_common(const Config& f, S& s, bool read_tau = true) {
  if (read_tau) s.tau = f.number_in("tau", 0.52, 0.5001, 5.0, "relaxation time tau > 1/2");
  s.collision = read_collision(f, s.magic);
  if (read_tau && lbm::bgk_too_close_to_half(s.collision, s.tau))  // (else: the caller, naming its key)
    f.fail("tau", "BGK needs tau >= 0.51 to stay stable; use collision: trt for smaller tau");
  s.precision = lbm::precision_from_string(f.choice("precision", "fp64", {"fp32", "fp64", "fp16s", "fp16c"}));
}

// The `psm` section: fraction method, operator, weight, pipeline, tile
// capacity, slots per cell and the drag-error limit of the start report.
void read_psm(const Config& ps, PsmOptions& o, int& slots, double& max_drag_error);

// The expected drag error of the scene as set up (imb/drag_error.hpp), told at
// `lbdem check` (validate_only) and at the start of a run (unless quiet); a
// warning when it is above psm.max_expected_drag_error (default: half the
// first paper's Table 1 error at this d/l in 3D; none in 2D).
void report_expected_drag_error(const DragErrorQuery& q, double max_drag_error, bool validate_only, bool quiet);

// The drag query of a scene of dimension dim (2: disks, the 2D map).
DragErrorQuery drag_query(double d, double tau, lbm::CollisionKind coll, double magic, const PsmOptions& o,
                          lbm::Precision prec, int dim);

// Every resolved PSM setting, where the rule's parameters came from (the case
// file or the rule) and the warnings for a combination the default rule does
// not cover (imb/psm_settings.hpp), told at `lbdem check` and at the start of
// a run (rank 0).
PsmSettings psm_settings(const Config& root, const DragErrorQuery& q, const char* pipeline, lbm::Precision prec,
                         bool tell);

}  // namespace lbdem::imb
