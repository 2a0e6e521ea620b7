// DEM scene drivers (filled in with the DEM module).
#include "cases/scenes.hpp"

namespace lbdem {
std::vector<std::string> dem_scene_names() { return {}; }
int run_dem_case(const Config& root, const RunOptions&) {
  root.fail("scene", "no DEM scenes are built into this binary");
}
}  // namespace lbdem
