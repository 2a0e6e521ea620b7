#include <algorithm>

#include "cases/scenes.hpp"
#include "core/error.hpp"

namespace lbdem {

std::vector<std::string> all_scene_names() {
  std::vector<std::string> all = lbm_scene_names();
  for (auto& s : dem_scene_names()) all.push_back(s);
  for (auto& s : psm_scene_names()) all.push_back(s);
  for (auto& s : cfd_scene_names()) all.push_back(s);
  return all;
}

int run_case(const Config& root, const RunOptions& opt) {
  const std::string scene = root.choice("scene", all_scene_names());
  auto has = [&](const std::vector<std::string>& v) { return std::find(v.begin(), v.end(), scene) != v.end(); };
  if (has(lbm_scene_names())) return run_lbm_case(root, opt);
  if (has(dem_scene_names())) return run_dem_case(root, opt);
  if (has(cfd_scene_names())) return run_cfd_case(root, opt);
  return run_psm_case(root, opt);
}

}  // namespace lbdem
