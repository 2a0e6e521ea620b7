#pragma once
// Every PSM setting a particle scene runs with, resolved (defaults and rules
// applied), where the rule-dependent ones came from, and the warnings a case
// file gets when it fixes one parameter of a default rule but not the others.
//
// Why: the defaults of the weighting (psm.weight: noble_torczynski_wall) and
// of Lambda (fluid.magic: auto, psm_magic_auto) are one rule, derived
// together (bench/imb/NOTES.md, "One rule for every tau"): the table of Lambda
// cancels the wall weighting's excess drag. A case file written before the
// rule that sets Lambda itself gets the new weighting with its old Lambda,
// a combination nobody measured, and its answer changes without a word. The
// run states the combination and its expected drag error (imb/drag_error.hpp,
// or "no estimate") at `lbdem check` and at the start of the run, and
// summary.json records every resolved setting, so that a later change of a
// default is visible in the output of the runs it affects.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "imb/drag_error.hpp"
#include "imb/psm.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/wall_lubrication.hpp"

namespace lbdem::imb {

inline const char* to_string(PsmWeight w) {
  return w == PsmWeight::Linear ? "linear" : w == PsmWeight::NobleTorczynski ? "noble_torczynski" : "noble_torczynski_wall";
}
inline const char* to_string(PsmVariant v) { return v == PsmVariant::NEBB ? "nebb" : "superposition"; }

// The scene as parsed: the drag query carries the resolved values (diameter
// d/l, tau, Lambda in use, TRT or BGK, weighting, operator, fractions, fp32);
// the flags say which of the rule's parameters the case file set itself.
struct PsmSettingsInput {
  DragErrorQuery q;
  bool magic_from_file = false;   // fluid.magic given as a number (not auto, not absent)
  bool weight_from_file = false;  // psm.weight given
  const char* pipeline = "";      // the resolved pipeline (fused / mapped)
  const char* precision = "";     // fluid.precision
};

struct PsmSettings {
  PsmSettingsInput in;
  double magic_rule = 0;        // Lambda of the rule at this d/l and tau (psm_magic_auto)
  DragErrorEstimate estimate;   // expected drag error of the setting (or why none)
  std::vector<std::string> warnings;
  WallLubricationSetting wall_lubrication;  // psm.wall_lubrication (off unless the scene reads it)
};

// psm.wall_lubrication as one JSON object: asked for, applied, the
// coefficients in use (0 when not applied), the fit's range and the note.
inline std::string wall_lubrication_json(const WallLubricationSetting& w) {
  std::ostringstream o;
  o.precision(17);
  o << "{\"requested\": \"" << (w.requested ? "on" : "off") << "\", \"applied\": " << (w.applied ? "true" : "false")
    << ", \"c\": " << w.k.c << ", \"p\": " << w.k.p << ", \"g_min\": " << w.k.g_min << ", \"g_max\": " << w.k.g_max
    << ", \"mu\": " << w.k.mu << ", \"walls\": " << w.k.count << ", \"fit_magic_min\": " << w.fit.w.magic_min
    << ", \"fit_magic_max\": " << w.fit.w.magic_max << ", \"fit_tau_min\": " << w.fit.tau_min
    << ", \"fit_tau_max\": " << w.fit.tau_max << ", \"note\": \"";
  for (char ch : w.note) o << (ch == '"' || ch == '\\' ? '\'' : ch);
  o << "\"}";
  return o.str();
}

namespace detail {
inline std::string fmt_num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}
inline std::string estimate_text(const DragErrorEstimate& e) {
  if (!e.known) return "no estimate (" + e.reason + ")";
  char b[64];
  std::snprintf(b, sizeof b, "%+.2f %%", 100 * e.error);
  return std::string(b) + " (" + e.reason + ")";
}
}  // namespace detail

// The resolved settings and the warnings for combinations a default rule
// does not cover: Lambda set in the file beside the wall rule's weighting,
// BGK (Lambda fixed at (tau - 1/2)^2) beside it, and Lambda auto (the wall
// rule's table) beside another weighting. Each names the combination and its
// expected drag error or "no estimate".
inline PsmSettings resolve_psm_settings(const PsmSettingsInput& in) {
  PsmSettings s;
  s.in = in;
  const auto& q = in.q;
  s.magic_rule = psm_magic_auto(q.diameter, q.tau);
  s.estimate = expected_drag_error(q);
  const std::string at = " at d/l = " + detail::fmt_num(q.diameter) + ", tau = " + detail::fmt_num(q.tau);
  const std::string weight =
      std::string("psm.weight = ") + to_string(q.weight) + (in.weight_from_file ? "" : " (the default: not set in the file)");
  const bool rule_weight = q.weight == PsmWeight::NobleTorczynskiWall;
  const bool off_rule = std::abs(q.magic - s.magic_rule) > 1e-3 * s.magic_rule;
  if (rule_weight && q.trt && in.magic_from_file && off_rule)
    s.warnings.push_back("fluid.magic = " + detail::fmt_num(q.magic) + " set in the case file with " + weight +
                         ": the wall rule's weighting was derived with its own Lambda (fluid.magic: auto = " +
                         detail::fmt_num(s.magic_rule) + at + "); expected drag error of this combination: " +
                         detail::estimate_text(s.estimate) +
                         ". Use fluid.magic: auto for the rule, or psm.weight: noble_torczynski to keep the classic "
                         "weighting this Lambda was chosen with");
  if (rule_weight && !q.trt)
    s.warnings.push_back("fluid.collision = bgk with " + weight +
                         ": BGK fixes Lambda at (tau - 1/2)^2, not the rule's (" + detail::fmt_num(s.magic_rule) + at +
                         "); expected drag error of this combination: " + detail::estimate_text(s.estimate));
  if (!rule_weight && q.trt && !in.magic_from_file)
    s.warnings.push_back(std::string("fluid.magic: auto (Lambda = ") + detail::fmt_num(q.magic) + at + ") with " +
                         weight + ": the Lambda table was derived for psm.weight: noble_torczynski_wall; expected "
                         "drag error of this combination: " + detail::estimate_text(s.estimate) +
                         ". Set fluid.magic to the value this weighting was validated with");
  return s;
}

// The settings as one JSON object (summary.json's "psm").
inline std::string psm_settings_json(const PsmSettings& s) {
  const auto& q = s.in.q;
  std::ostringstream o;
  o.precision(17);
  o << "{\"weight\": \"" << to_string(q.weight) << "\", \"weight_from\": \"" << (s.in.weight_from_file ? "file" : "default")
    << "\", \"collision\": \"" << (q.trt ? "trt" : "bgk") << "\", \"magic\": " << (q.trt ? q.magic : (q.tau - 0.5) * (q.tau - 0.5))
    << ", \"magic_from\": \"" << (!q.trt ? "bgk" : s.in.magic_from_file ? "file" : "rule")
    << "\", \"magic_rule\": " << s.magic_rule << ", \"weight_t\": " << psm_weight_t(q.tau, q.weight)
    << ", \"operator\": \"" << to_string(q.variant) << "\", \"even_relaxation\": " << q.even_relaxation
    << ", \"fraction\": \"" << to_string(q.method)
    << "\", \"pipeline\": \"" << s.in.pipeline << "\", \"precision\": \"" << s.in.precision << "\", \"tau\": " << q.tau
    << ", \"diameter\": " << q.diameter << ", \"expected_drag_error\": ";
  if (s.estimate.known) o << s.estimate.error;
  else o << "null";
  o << ", \"expected_drag_error_note\": \"";
  for (char c : s.estimate.reason) o << (c == '"' || c == '\\' ? '\'' : c);
  o << "\", \"warnings\": " << s.warnings.size() << ", \"wall_lubrication\": " << wall_lubrication_json(s.wall_lubrication)
    << "}";
  return o.str();
}

}  // namespace lbdem::imb
