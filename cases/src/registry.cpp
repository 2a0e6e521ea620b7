// The scenes `lbdem run` knows. A scene family is a file
// cases/src/NAME_case.cpp (built by the glob in cases/CMakeLists.txt) that
// defines NAME_scene_names() and run_NAME_case(); it is known once it has
// its line X(NAME) below.
#include <algorithm>

#include "cases/scenes.hpp"
#include "core/error.hpp"

#define LBDEM_SCENE_FAMILIES(X) \
  X(lbm)                        \
  X(dem)                        \
  X(fixed_sphere)               \
  X(particles)                  \
  X(cfd)                        \
  X(couette)

namespace lbdem {

#define LBDEM_DECLARE_FAMILY(name)                \
  std::vector<std::string> name##_scene_names(); \
  int run_##name##_case(const Config& root, const RunOptions& opt);
LBDEM_SCENE_FAMILIES(LBDEM_DECLARE_FAMILY)
#undef LBDEM_DECLARE_FAMILY

namespace {
struct Family {
  std::vector<std::string> (*names)();
  int (*run)(const Config&, const RunOptions&);
};
const std::vector<Family>& families() {
#define LBDEM_FAMILY_ENTRY(name) Family{&name##_scene_names, &run_##name##_case},
  static const std::vector<Family> all{LBDEM_SCENE_FAMILIES(LBDEM_FAMILY_ENTRY)};
#undef LBDEM_FAMILY_ENTRY
  return all;
}
}  // namespace

std::vector<std::string> all_scene_names() {
  std::vector<std::string> all;
  for (const Family& f : families())
    for (auto& s : f.names()) all.push_back(s);
  return all;
}

int run_case(const Config& root, const RunOptions& opt) {
  const std::string scene = root.choice("scene", all_scene_names());
  for (const Family& f : families()) {
    const auto names = f.names();
    if (std::find(names.begin(), names.end(), scene) != names.end()) return f.run(root, opt);
  }
  throw ConfigError("scene '" + scene + "' has no runner");  // (choice() refused unknown names)
}

}  // namespace lbdem
