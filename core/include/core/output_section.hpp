#pragma once
// The `output` section, read the same way by every scene: the run folder, the
// snapshot interval and the scene's other output keys. A scene names the keys
// it has (OutputKey); the section's finish() refuses any other, naming the
// key as the file wrote it.
#include <limits>
#include <string>
#include <vector>

#include "core/config.hpp"

namespace lbdem {

// The keys a scene's `output` section has besides `directory`.
enum OutputKey : unsigned {
  kOutputInterval = 1,  // interval: steps between snapshots (0: none)
  kOutputSeries = 2,    // series_interval: steps between CSV samples
  kOutputTrack = 4,     // track: particle ids whose paths are written
  kOutputFields = 8,    // field_precision, background, final
};

struct OutputSettings {
  std::string directory;
  long interval = 0;
  long series_interval = 100;
  std::vector<long> track;
  // Fields on disk: "fp64", "fp32", or "storage" (the populations' precision:
  // float64 for fp64 runs, float32 for fp32 and the 16-bit storages).
  std::string field_precision = "storage";
  // Snapshots copied to host memory and written by a host thread while the
  // run goes on; off: written slab by slab, no host copy of the grid.
  bool background = false;
  // Fields and particles at the end of the run (off: the periodic snapshots
  // only, e.g. a speed measurement on a grid whose fields fill tens of GB).
  bool final = true;
};

// Reads root's `output` section: directory and the keys `keys` names, in the
// order above. An empty default_directory makes output.directory required
// (and the section with it); else the section is optional and that is the
// folder when it gives none. interval is at most max_interval.
OutputSettings read_output(const Config& root, unsigned keys, const std::string& default_directory = "",
                           long max_interval = std::numeric_limits<long>::max());

}  // namespace lbdem
