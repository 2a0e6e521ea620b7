// The `output` section of every scene (core/output_section.hpp).
#include "core/output_section.hpp"

#include <optional>

namespace lbdem {

OutputSettings read_output(const Config& root, unsigned keys, const std::string& default_directory,
                           long max_interval) {
  OutputSettings s;
  const bool required = default_directory.empty();
  const std::optional<Config> o = required ? std::optional<Config>(root.section("output")) : root.optional_section("output");
  s.directory = default_directory;
  if (!o) return s;
  s.directory = required ? o->text("directory") : o->text("directory", default_directory);
  if (keys & kOutputInterval) s.interval = o->integer_in("interval", 0, 0, max_interval);
  if (keys & kOutputSeries) s.series_interval = o->integer_in("series_interval", 100, 1, std::numeric_limits<long>::max());
  if ((keys & kOutputTrack) && o->has("track"))
    for (long id : o->integers("track", 1, 64, 0, std::numeric_limits<long>::max())) s.track.push_back(id);
  if (keys & kOutputFields) {
    s.field_precision = o->choice("field_precision", "storage", {"fp64", "fp32", "storage"});
    s.background = o->boolean("background", false);
    s.final = o->boolean("final", true);
  }
  o->finish();
  return s;
}

}  // namespace lbdem
