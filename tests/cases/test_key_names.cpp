// Every message names keys as the user wrote them. For every shipped case
// file, every key its scene accepts (read from the file or defaulted) is set
// to a wrong type, zero, -1, a million times and a millionth of its value; the
// check must then refuse with exit code 2 or 4 (or accept), and
//  - a wrong type names that key, with its full dotted path;
//  - every dotted key name in any message is a key of that scene family
//    (never an internal name such as coupling.dem_substeps, material.stiffness
//    in a resolved scene, coupling.gravity).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <map>
#include <set>
#include <utility>

#include "case_mutation.hpp"
#include "cases/scenes.hpp"

namespace {

using namespace lbdem;
using test::check_case;

std::string family(const std::string& scene) {
  for (auto& s : lbm_scene_names())
    if (s == scene) return "fluid";
  return scene;  // dem, particles, fixed_sphere
}

// "a.b[1].c" -> {"a", "b[1]", "c"}; sets `value` there (creating missing sections).
std::string with_value(const std::string& text, const std::string& key, const YAML::Node& value) {
  YAML::Node root = YAML::Load(text);
  YAML::Node n = root;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = key.find('.', start);
    std::string part = key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    long idx = -1;
    if (const auto b = part.find('['); b != std::string::npos) {
      idx = std::stol(part.substr(b + 1));
      part = part.substr(0, b);
    }
    const bool last = dot == std::string::npos;
    if (last && idx < 0) {
      n[part] = value;
      break;
    }
    YAML::Node next = n[part];
    if (idx >= 0) {
      YAML::Node item = next[static_cast<std::size_t>(idx)];
      if (last) {
        next[static_cast<std::size_t>(idx)] = value;
        break;
      }
      n.reset(item);
    } else {
      n.reset(next);
    }
    start = dot + 1;
  }
  YAML::Emitter e;
  e << root;
  return e.c_str();
}

YAML::Node scaled(const YAML::Node& v, double f) {
  if (v.IsScalar()) {
    try {
      return YAML::Node(v.as<double>() * f);
    } catch (const YAML::Exception&) {
      return YAML::Node(v.Scalar());
    }
  }
  if (v.IsSequence()) {
    YAML::Node out(YAML::NodeType::Sequence);
    for (std::size_t i = 0; i < v.size(); ++i) out.push_back(scaled(v[i], f));
    return out;
  }
  return YAML::Node(YAML::Clone(v));
}

// The node at `key` in `text` (null when the key is defaulted).
YAML::Node value_at(const std::string& text, const std::string& key) {
  YAML::Node n = YAML::Load(text);
  std::size_t start = 0;
  while (n) {
    const std::size_t dot = key.find('.', start);
    std::string part = key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    long idx = -1;
    if (const auto b = part.find('['); b != std::string::npos) {
      idx = std::stol(part.substr(b + 1));
      part = part.substr(0, b);
    }
    if (!n.IsMap()) return YAML::Node();
    YAML::Node next = n[part];
    if (idx >= 0 && next && next.IsSequence()) next.reset(next[static_cast<std::size_t>(idx)]);
    n.reset(next);
    if (dot == std::string::npos) return n;
    start = dot + 1;
  }
  return YAML::Node();
}

TEST(KeyNames, EveryKeyOfEveryShippedCaseIsNamedAsWritten) {
  const auto files = test::shipped_cases();
  ASSERT_GE(files.size(), 10u);
  // Keys each scene family accepts: what the shipped files make it read.
  std::map<std::string, std::set<std::string>> accepted;
  std::set<std::string> sections = {"coupling", "material", "fixed_sphere", "dem", "fluid", "physics"};
  std::map<std::string, std::vector<std::string>> keys_of;
  for (const auto& f : files) {
    const auto o = check_case(f.text, f.name);
    ASSERT_EQ(o.code, 0) << f.name << ": " << o.message;
    const std::string fam = family(YAML::Load(f.text)["scene"].as<std::string>());
    for (const auto& k : o.keys) {
      accepted[fam].insert(k);
      sections.insert(k.substr(0, k.find_first_of(".[")));
    }
    keys_of[f.name] = o.keys;
  }
  long runs = 0, refusals = 0;
  for (const auto& f : files) {
    const std::string fam = family(YAML::Load(f.text)["scene"].as<std::string>());
    const auto& keys = keys_of[f.name];
    for (const auto& key : keys) {
      // Leaves only: a section's keys are walked themselves.
      const bool section = std::any_of(keys.begin(), keys.end(), [&](const std::string& k) {
        return k.size() > key.size() && k.compare(0, key.size(), key) == 0 && (k[key.size()] == '.' || k[key.size()] == '[');
      });
      if (section) continue;
      const YAML::Node v = value_at(f.text, key);
      std::vector<std::pair<std::string, YAML::Node>> values = {{"type", YAML::Node("not-a-valid-value")},
                                                                {"zero", YAML::Node(0)},
                                                                {"minus one", YAML::Node(-1)}};
      if (v) {
        values.push_back({"x1e6", scaled(v, 1e6)});
        values.push_back({"x1e-6", scaled(v, 1e-6)});
      } else {
        values.push_back({"1e6", YAML::Node(1e6)});
      }
      for (const auto& [what, value] : values) {
        const std::string text = with_value(f.text, key, value);
        const auto o = check_case(text, f.name);
        ++runs;
        SCOPED_TRACE(f.name + ": " + key + " set to " + what);
        EXPECT_TRUE(o.code == 0 || o.code == 2 || o.code == 4) << o.code << ": " << o.message;
        if (o.code == 0) continue;
        ++refusals;
        EXPECT_EQ(o.message.find('\n'), std::string::npos) << o.message;
        if (what == "type" && key != "output.directory") {
          EXPECT_NE(o.message.find(key), std::string::npos) << "the message does not name '" << key << "': " << o.message;
        }
        for (const auto& name : test::dotted_names(o.message, f.name, sections))
          EXPECT_TRUE(accepted[fam].count(name)) << "'" << name << "' is not a key of a " << fam << " case file: "
                                                 << o.message;
      }
    }
  }
  EXPECT_GT(runs, 300);
  EXPECT_GT(refusals, runs / 3);
}

}  // namespace

namespace {

// The coupled, fixed-sphere and gas code below the scenes names its
// parameters by the keys the scene's reader hands it (imb::CoupledKeys,
// imb::FixedSphereSpec::keys, cfd::GasKeys), never by their C++ fields: for
// each such parameter a bad value in a shipped case file is refused naming the
// key as the user wrote it, and not the field's name.
struct Refusal {
  const char* file;
  const char* from;  // text of the shipped file replaced ...
  const char* to;    // ... by this
  const char* key;    // named in the message
  const char* field;  // not named in the message
  const char* from2 = nullptr;  // a second replacement, if any
  const char* to2 = nullptr;
};

TEST(KeyNames, LibraryChecksNameTheKeysOfTheFile) {
  const Refusal cases[] = {
      // The particles scene in lattice units.
      {"settling_sphere.yaml", "substeps: 30", "substeps: 1", "key 'dem.substeps' = 1", "coupling.dem_substeps"},
      {"settling_sphere.yaml", "stiffness: 5000", "stiffness: 5.0e8", "soften dem.stiffness", "material.stiffness"},
      {"settling_sphere.yaml", "tau: 0.6", "tau: 0.501", "under physics.gravity", "coupling.gravity"},
      {"settling_sphere.yaml", "restitution: 0.5", "restitution: 2", "dem.restitution", "material.restitution"},
      {"settling_sphere.yaml", "restitution: 0.5", "restitution: 0.5, wall_restitution: 0", "dem.wall_restitution",
       "material.wall_restitution"},
      {"settling_sphere.yaml", "restitution: 0.5", "restitution: 0.5, wall_stiffness: -1", "dem.wall_stiffness",
       "material.wall_stiffness"},
      {"settling_sphere.yaml", "restitution: 0.5", "restitution: 0.5, friction: -1", "dem.friction", "material.friction"},
      {"settling_sphere.yaml", "restitution: 0.5", "restitution: 0.5, wall_friction: 11", "dem.wall_friction",
       "material.wall_friction"},
      {"settling_sphere.yaml", "time:", "psm: {fraction: linear, pipeline: fused, slots: 5}\ntime:",
       "psm.slots (K) = 5", "coupling.slots"},
      {"settling_sphere.yaml", "position: [21, 80, 21]", "position: [21, 200, 21]", "(domain.cells)", "dem.hi"},
      {"settling_sphere.yaml", "periodic: [0, 0, 0]", "periodic: [0, 0, 2]", "domain.periodic", "dem.periodic"},
      {"settling_sphere_periodic.yaml", "gravity: [0, -9.81, 0]", "gravity: [0, -9.81, 0], balance_weight: false",
       "physics.balance_weight", "fluid.body_force"},
      // ... in SI units: the grid's size and the particles' density are other keys.
      {"settling_sphere_periodic.yaml", "gravity: [0, -9.81, 0]", "gravity: [0, -9810, 0]", "a lower particles.density;",
       "particles.density_ratio"},
      {"settling_sphere_periodic.yaml", "position: [0.0016, 0.0016, 0.0016]", "position: [0.01, 0.0016, 0.0016]",
       "(domain.size)", "domain.cells"},
      // The fixed sphere.
      {"fixed_sphere.yaml", "dim: 3", "dim: 4", "geometry.dim", "fixed_sphere.dim"},
      {"fixed_sphere.yaml", "chi: 0.5", "chi: 0.9", "geometry.chi", "fixed_sphere.chi"},
      {"fixed_sphere.yaml", "diameter: 10", "diameter: 1", "geometry.diameter", "fixed_sphere.diameter"},
      {"fixed_sphere.yaml", "slots: 4", "slots: 5, pipeline: fused", "psm.slots (K) = 5", "coupling.slots",
       "fraction: exact", "fraction: linear"},
      // The fluidized bed's gas.
      {"fluidized_bed_small.yaml", "density: 1.225", "density: -1", "gas.density", "gas.rho"},
      {"fluidized_bed_small.yaml", "viscosity: 1.8e-5", "viscosity: 0", "gas.viscosity", "gas.mu"},
      {"fluidized_bed_small.yaml", "void_fraction: linear", "void_fraction: linear\n  pressure_solver: {max_iterations: 0}",
       "gas.pressure_solver.max_iterations", "gas.cg_"},
      {"fluidized_bed_small.yaml", "void_fraction: linear", "void_fraction: linear\n  pressure_solver: {tolerance: 0}",
       "gas.pressure_solver.tolerance", "gas.cg_"},
      {"fluidized_bed_small.yaml", "void_fraction: linear", "void_fraction: linear\n  pressure_solver: {poll_every: 0}",
       "gas.pressure_solver.poll_every", "gas.cg_"},
      {"fluidized_bed_small.yaml", "hi: [4.0e-3, 4.0e-3, 0.08]", "hi: [1.2e-2, 4.0e-3, 0.08]",
       "gas.pressure_solver.type = multigrid", "gas.pressure_solver =", "void_fraction: linear",
       "void_fraction: linear\n  pressure_solver: {type: multigrid}"},
  };
  const auto files = lbdem::test::shipped_cases();
  for (const Refusal& r : cases) {
    SCOPED_TRACE(std::string(r.file) + ": " + r.to);
    const auto it = std::find_if(files.begin(), files.end(), [&](const auto& f) { return f.name == r.file; });
    ASSERT_NE(it, files.end());
    std::string text = it->text;
    for (const auto& [from, to] : {std::pair{r.from, r.to}, std::pair{r.from2, r.to2}}) {
      if (!from) continue;
      const auto at = text.find(from);
      ASSERT_NE(at, std::string::npos) << from;
      text.replace(at, std::string(from).size(), to);
    }
    const auto o = lbdem::test::check_case(text, r.file);
    EXPECT_EQ(o.code, 2) << o.message;
    EXPECT_NE(o.message.find(r.key), std::string::npos) << o.message;
    EXPECT_EQ(o.message.find(r.field), std::string::npos) << o.message;
  }
}

}  // namespace
