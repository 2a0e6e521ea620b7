#pragma once
// How long a run is, as every scene's `time` section says it: exactly one of
// time.steps (a step count) or time.end (simulated seconds). time.end_time is
// the old spelling of time.end: it still works, with a warning that names the
// new key. Messages name the key as the file wrote it.
#include <optional>
#include <string>

#include "core/config.hpp"

namespace lbdem {

struct RunLength {
  std::optional<long> steps;    // time.steps
  std::optional<double> end;    // time.end [s]
  std::string end_key = "end";  // the spelling the file used: "end" or "end_time"
};

// Reads time.steps (in [min_steps, max_steps]) or time.end of section `t`.
RunLength read_run_length(const Config& t, long min_steps, long max_steps);

// The key of section `t` that gives the end time: "end_time" where the file
// uses the old spelling, else "end".
std::string end_key(const Config& t);

}  // namespace lbdem
