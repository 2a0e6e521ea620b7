// How long a run is (core/run_length.hpp).
#include "core/run_length.hpp"

#include <spdlog/spdlog.h>

namespace lbdem {

std::string end_key(const Config& t) { return t.has("end_time") ? "end_time" : "end"; }

RunLength read_run_length(const Config& t, long min_steps, long max_steps) {
  RunLength r;
  r.end_key = end_key(t);
  if (r.end_key == "end_time") {
    if (t.has("end")) t.fail("end_time", "is the old spelling of '" + t.full_key("end") + "': give one of them");
    spdlog::warn("{}: key '{}' is deprecated; write it as '{}'", t.source(), t.full_key("end_time"), t.full_key("end"));
  }
  const bool has_steps = t.has("steps"), has_end = t.has(r.end_key);
  if (has_steps == has_end)
    t.fail(has_steps ? r.end_key : "steps", "give exactly one of 'time.steps' (a step count) or 'time.end' (seconds)");
  if (has_steps) r.steps = t.integer_in("steps", min_steps, max_steps);
  else r.end = t.positive(r.end_key);
  return r;
}

}  // namespace lbdem
