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

#include <map>
#include <set>

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

#include "../../cases/src/scene_checks.hpp"

namespace {

TEST(KeyNames, InternalNamesAreRewrittenWholeNamesOnly) {
  const auto& m = lbdem::cases::key_map("particles");
  EXPECT_EQ(lbdem::cases::user_keys("use coupling.dem_substeps >= 3 or soften the contacts (material.stiffness)", m),
            "use dem.substeps >= 3 or soften the contacts (dem.stiffness)");
  EXPECT_EQ(lbdem::cases::user_keys("coupling.gravity = (0, 1, 0) differs from dem.gravity", m),
            "physics.gravity = (0, 1, 0) differs from physics.gravity");
  // Only whole dotted names: longer names and names inside others stay.
  EXPECT_EQ(lbdem::cases::user_keys("xcoupling.gravity coupling.gravity_y a.coupling.gravity", m),
            "xcoupling.gravity coupling.gravity_y a.coupling.gravity");
  EXPECT_EQ(lbdem::cases::user_keys("coupling.slots (K) = 80", lbdem::cases::key_map("fixed_sphere")), "psm.slots (K) = 80");
  // The DEM scene's own sections keep their names.
  EXPECT_EQ(lbdem::cases::user_keys("material.stiffness", lbdem::cases::key_map("dem")), "material.stiffness");
}

// The coupled checks (imb/) word the cell-Reynolds refusal with
// coupling.gravity; the scene reports physics.gravity.
TEST(KeyNames, CoupledCheckMessagesUseTheFileKeys) {
  auto files = lbdem::test::shipped_cases();
  const auto it = std::find_if(files.begin(), files.end(), [](const auto& f) { return f.name == "settling_sphere.yaml"; });
  ASSERT_NE(it, files.end());
  std::string text = it->text;
  text.replace(text.find("tau: 0.6"), 8, "tau: 0.501");
  const auto o = lbdem::test::check_case(text, "settling_sphere.yaml");
  ASSERT_EQ(o.code, 2) << o.message;
  EXPECT_NE(o.message.find("fluid.tau"), std::string::npos) << o.message;
  EXPECT_NE(o.message.find("physics.gravity"), std::string::npos) << o.message;
  EXPECT_EQ(o.message.find("coupling."), std::string::npos) << o.message;
}

}  // namespace
