#pragma once
// What every lbdem benchmark reports beside its own numbers: the device it ran
// on, the date, the source commit, and the copy bandwidth of the same device
// measured in the same run (the reference a memory-bound kernel is compared
// with; bench/NOTES.md, "Method").
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "core/exec.hpp"

namespace lbdem::bench {

// Copy bandwidth of backend b in bytes read + written per second: a
// device-to-device cudaMemcpyAsync of `bytes` timed with CUDA events on the
// GPU; on the host a memcpy split over the current OpenMP threads, timed with
// the steady clock. Median of the repeats after warm-up copies.
double copy_bandwidth(Backend b, std::size_t bytes);

// CUDA device 0's name for Backend::Cuda; the CPU model name for Backend::Host.
std::string device_name(Backend b);

// Today's date (UTC), YYYY-MM-DD.
std::string utc_date();

// The source commit: $LBDEM_COMMIT when set (a tree without .git, e.g. from
// `git archive`), else the short hash CMake read when it configured the build.
std::string git_commit();

// The JSON members every benchmark file starts with (no braces, no trailing
// comma), one per line with two spaces of indent:
//   "benchmark": ..., "device": ..., "date": ..., "commit": ...,
//   "copy_bandwidth_GBs": {"<name>": GB/s, ...}   (1 GB = 1e9 bytes, read + written)
// copy_bw holds (name, bytes/s) as copy_bandwidth() returns them.
std::string json_header(const std::string& benchmark, const std::string& device,
                        const std::vector<std::pair<std::string, double>>& copy_bw);

// s with JSON string escapes applied (quotes, backslashes, control characters).
std::string json_escape(const std::string& s);

}  // namespace lbdem::bench
