#include <algorithm>

#include "cases/scenes.hpp"
#include "core/error.hpp"
#include "halo/comm.hpp"

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
  // The coupled particles scene runs on one rank: its PSM step already runs
  // on a cut grid (imb::PsmCoupling with lbm::FluidHalo), but the scene does
  // not yet sum the hydrodynamic forces of particles shared by several ranks.
  const halo::Comm& comm = halo::Comm::world();
  if (comm.distributed() && scene == "particles")
    throw ConfigError("scene '" + scene + "' runs on one rank (started here on " + std::to_string(comm.size()) +
                      " ranks): run it without mpirun (one GPU), or use a fluid scene, fixed_sphere or dem on several ranks");
  return run_psm_case(root, opt);
}

}  // namespace lbdem
