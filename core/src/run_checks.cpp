// Checks every scene runs while its case file is parsed (core/run_checks.hpp).
#include "core/run_checks.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <utility>

#include "core/buffer.hpp"
#include "core/error.hpp"

namespace lbdem {

namespace checks {

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", v + 0.0);  // + 0.0: no "-0"
  return b;
}
std::string vec(const Vec3d& v, int dim) {
  std::string s("[");  // appended piecewise: GCC 12 warns (-Wrestrict, a false positive) on "[" + std::string
  for (int a = 0; a < dim; ++a) {
    s += num(v[a]);
    s += a + 1 < dim ? ", " : "]";
  }
  return s;
}
const char* axis_name(int a) { return a == 0 ? "x" : a == 1 ? "y" : "z"; }
std::string mib(double bytes) { return num(bytes / 1048576.0) + " MiB"; }

}  // namespace checks

using checks::axis_name;
using checks::mib;
using checks::num;

void check_min_cells(const Config& root, const std::string& key, const std::vector<long>& cells, long min_cells,
                     const std::string& what) {
  for (std::size_t a = 0; a < cells.size(); ++a)
    if (cells[a] < min_cells)
      throw ConfigError(root.source() + ": key '" + key + "': " + std::to_string(cells[a]) + " cells along " +
                        axis_name(static_cast<int>(a)) + " is too few: " + what + "; use at least " +
                        std::to_string(min_cells));
}

std::string memory_table(const MemoryUse& m, double cells) {
  std::string out;
  char line[160];
  auto row = [&](const std::string& name, double bytes) {
    std::snprintf(line, sizeof line, "  %-26s %9.2f B/cell %12.1f MiB\n", name.c_str(), bytes / std::max(cells, 1.0),
                  bytes / 1048576.0);
    out += line;
  };
  for (const auto& it : m.items) row(it.name, static_cast<double>(it.bytes));
  row("total", static_cast<double>(m.total()));
  return out;
}

void check_memory(const Config& root, Backend b, double device_bytes, double host_bytes, const std::string& key,
                  const std::string& what, const std::string& fix) {
  const double dev_have = static_cast<double>(backend_free_bytes(b));
  const double host_have = static_cast<double>(backend_free_bytes(Backend::Host));
  const bool host = b == Backend::Host;
  const double host_need = host_bytes + (host ? device_bytes : 0);
  if (!host && device_bytes > dev_have)
    throw ResourceError(root.source() + ": " + key + ": " + what + " needs at least " + mib(device_bytes) +
                        " of GPU memory but " + mib(dev_have) + " are free; " + fix);
  if (host_need > host_have)
    throw ResourceError(root.source() + ": " + key + ": " + what + " needs at least " + mib(host_need) +
                        " of host memory but " + mib(host_have) + " are free; " + fix);
}

void check_plan(const Config& root, bool force, double steps, double cell_updates, double particle_steps,
                const std::string& steps_key) {
  if (!(steps < 1e18))  // beyond a 64-bit step counter (and a computer's lifetime)
    throw ConfigError(root.source() + ": " + steps_key + " plans " + num(steps) +
                      " steps, more than a 64-bit step counter holds; check those keys");
  if (force) return;
  const double per_step = std::max(kLeastSecondsPerStep, cell_updates / kFastestCellUpdatesPerSecond +
                                                             particle_steps / kFastestParticleStepsPerSecond);
  const double secs = steps * per_step;
  if (secs > kMaxPlannedSeconds)
    throw ConfigError(root.source() + ": " + steps_key + " plans " + num(steps) + " steps" +
                      (cell_updates > 0 ? " of " + num(cell_updates) + " cells" : std::string()) +
                      (particle_steps > 0 ? (cell_updates > 0 ? " and " : " of ") + num(particle_steps) +
                                                " particles"
                                          : std::string()) +
                      ": at least " + num(secs / kMaxPlannedSeconds) +
                      " years of wall time even at the fastest speed this code reaches on one GPU; check those keys "
                      "(and the values they follow from), or pass --force to start it anyway");
}

std::size_t parse_memory_size(const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  std::string unit = text.substr(used);
  for (auto& ch : unit) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  static const std::pair<const char*, double> units[] = {
      {"", 1},           {"B", 1},          {"K", 0x1p10},     {"KIB", 0x1p10}, {"KB", 1e3}, {"M", 0x1p20},
      {"MIB", 0x1p20},   {"MB", 1e6},       {"G", 0x1p30},     {"GIB", 0x1p30}, {"GB", 1e9}, {"T", 0x1p40},
      {"TIB", 0x1p40},   {"TB", 1e12}};
  for (const auto& [name, scale] : units)
    if (used > 0 && unit == name && v * scale >= 1 && v * scale < 0x1p60)
      return static_cast<std::size_t>(v * scale);
  throw ConfigError("--memory = '" + text + "': give a positive size such as 80GiB, 512M or 141GB (K/M/G/T and "
                    "KiB/MiB/GiB/TiB are powers of 1024, KB/MB/GB/TB powers of 1000)");
}

}  // namespace lbdem
