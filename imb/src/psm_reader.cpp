// The readers of a resolved scene's sections (imb/psm_reader.hpp).
#include "imb/psm_reader.hpp"

#include <cmath>

#include <spdlog/spdlog.h>

#include "core/error.hpp"

namespace lbdem::imb {

lbm::CollisionKind read_collision(const Config& f, double& magic, const std::string& def) {
  const auto c = f.choice("collision", def, {"bgk", "trt"});
  // The PSM drag depends on Lambda (bench/imb/NOTES.md, "Fixed-sphere drag"): auto
  // takes Lambda by d/l and tau (psm_magic_auto), the setting the drag map is built on.
  if (!f.has("magic") || f.text("magic") == "auto") {
    if (f.has("magic")) f.accept("magic");
    magic = kMagicAuto;
  } else {
    magic = f.number_in("magic", 1e-6, 10.0,
                        "TRT parameter Lambda, or auto (by d/l and tau: the mapped PSM setting, psm_magic_auto)");
  }
  return c == "bgk" ? lbm::CollisionKind::BGK : lbm::CollisionKind::TRT;
}

double resolve_magic(double magic, double d, double tau) {
  return magic == kMagicAuto ? psm_magic_auto(d, tau) : magic;
}

void read_psm(const Config& ps, PsmOptions& o, int& slots, double& max_drag_error) {
  const auto fr = ps.choice("fraction", "exact", {"exact", "table", "linear"});
  o.map.method = fr == "table" ? FractionMethod::Table : fr == "linear" ? FractionMethod::Linear
                                                                             : FractionMethod::Exact;
  o.variant = ps.choice("operator", "nebb", {"nebb", "superposition"}) == "nebb" ? PsmVariant::NEBB
                                                                                 : PsmVariant::Superposition;
  o.even_relaxation = ps.number_in("even_relaxation", 0.0, 0.0, 1.0,
                                   "the least share phi of omega+ at which a cell's even populations relax "
                                   "(0: off, the odd-part NEBB; 1: in full)");
  if (o.even_relaxation > 0 && o.variant != PsmVariant::NEBB)
    ps.fail("even_relaxation", "the superposition operator relaxes the even part already; even_relaxation applies "
                               "to operator: nebb (give 0 or leave it out)");
  const auto we = ps.choice("weight", "noble_torczynski_wall", {"noble_torczynski_wall", "noble_torczynski", "linear"});
  o.weight = we == "linear"             ? PsmWeight::Linear
             : we == "noble_torczynski" ? PsmWeight::NobleTorczynski
                                        : PsmWeight::NobleTorczynskiWall;
  max_drag_error = ps.has("max_expected_drag_error")
                       ? ps.number_in("max_expected_drag_error", 1e-6, 1.0,
                                      "relative drag error (0.02 = 2 %) above which the start report warns")
                       : kMaxDragErrorBar;
  o.map.table_in_constant = ps.boolean("table_in_constant", false);
  const auto pl = ps.choice("pipeline", "auto", {"auto", "fused", "mapped"});
  o.pipeline = pl == "fused" ? PsmPipeline::Fused : pl == "mapped" ? PsmPipeline::Mapped : PsmPipeline::Auto;
  o.tile_capacity = static_cast<int>(ps.integer_in("tile_capacity", 64, 1, kFusedMaxCapacity));
  slots = static_cast<int>(ps.integer_in("slots", 4, 1, 64));
  if (o.pipeline == PsmPipeline::Fused) {  // refuse now, before any output is written
    PsmOptions probe = o;
    if (probe.map.method == FractionMethod::Table) probe.map.table = nullptr;
    try {
      (void)resolve_pipeline(probe, slots, ps.full_key("slots"));
    } catch (const ConfigError& e) {
      ps.fail("pipeline", e.what());
    }
  }
}

void report_expected_drag_error(const DragErrorQuery& q, double max_drag_error, bool validate_only, bool quiet) {
  const auto e = expected_drag_error(q);
  const bool tell = validate_only || !quiet;  // `lbdem check` is quiet otherwise but tells this
  if (!e.known) {
    if (tell)
      spdlog::info("expected drag error at d/l = {}, tau = {}: no estimate ({})", q.diameter, q.tau, e.reason);
    return;
  }
  // 2D has no published bar (the paper's Table 1 is of spheres): without
  // psm.max_expected_drag_error the estimate is told, never warned about.
  if (max_drag_error == kMaxDragErrorBar && !e.has_bar) {
    if (tell)
      spdlog::info("expected drag error at d/l = {}, tau = {}: {:+.2f}% ({})", q.diameter, q.tau, 100 * e.error,
                   e.reason);
    return;
  }
  const double limit = max_drag_error == kMaxDragErrorBar ? e.bar : max_drag_error;
  if (std::abs(e.error) > limit)
    spdlog::warn("expected drag error at d/l = {}, tau = {}: {:+.2f}% ({}), above psm.max_expected_drag_error = {:.2f}%: "
                 "a larger particle diameter in cells (a finer grid) or a tau nearer 0.5 lowers it",
                 q.diameter, q.tau, 100 * e.error, e.reason, 100 * limit);
  else if (tell)
    spdlog::info("expected drag error at d/l = {}, tau = {}: {:+.2f}% ({}; limit {:.2f}%)", q.diameter, q.tau,
                 100 * e.error, e.reason, 100 * limit);
}

DragErrorQuery drag_query(double d, double tau, lbm::CollisionKind coll, double magic, const PsmOptions& o,
                               lbm::Precision prec, int dim) {
  DragErrorQuery q;
  q.dim = dim;
  q.diameter = d;
  q.tau = tau;
  q.trt = coll == lbm::CollisionKind::TRT;
  q.magic = magic;
  q.weight = o.weight;
  q.variant = o.variant;
  q.even_relaxation = o.even_relaxation;
  q.method = o.map.method;
  q.fp32 = prec == lbm::Precision::FP32;
  return q;
}

PsmSettings psm_settings(const Config& root, const DragErrorQuery& q, const char* pipeline,
                              lbm::Precision prec, bool tell) {
  PsmSettingsInput in;
  in.q = q;
  const Config f = root.section("fluid");
  in.magic_from_file = f.has("magic") && f.text("magic") != "auto";
  const auto ps = root.optional_section("psm");
  in.weight_from_file = ps && ps->has("weight");
  in.pipeline = pipeline;
  in.precision = lbm::to_string(prec);
  auto r = resolve_psm_settings(in);
  for (const auto& w : r.warnings)
    if (tell) spdlog::warn("{}: {}", root.source(), w);
  return r;
}


}  // namespace lbdem::imb
