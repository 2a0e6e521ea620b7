#pragma once
// Shared by the key-name walk and the fuzz test: the shipped case files, an
// in-process `lbdem check` (the same parse and checks, the exit code main()
// would give), and the dotted key names a message mentions.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cases/scenes.hpp"
#include "core/config.hpp"
#include "core/error.hpp"

namespace lbdem::test {

struct CaseFile {
  std::string name;  // file name, e.g. "suspension.yaml"
  std::string text;
};

// Every shipped case file, with the edits that keep a validation of it fast
// (the granular gas packs 10^5 particles; the rotating sphere's weight
// balance integrates solid fractions): keys and structure are unchanged.
inline std::vector<CaseFile> shipped_cases() {
  namespace fs = std::filesystem;
  std::vector<CaseFile> out;
  for (const auto& e : fs::directory_iterator(fs::path(LBDEM_SOURCE_DIR) / "cases")) {
    if (e.path().extension() != ".yaml") continue;
    std::ifstream in(e.path());
    std::stringstream ss;
    ss << in.rdbuf();
    std::string t = ss.str();
    auto sub = [&](const std::string& a, const std::string& b) {
      for (std::size_t p = t.find(a); p != std::string::npos; p = t.find(a, p + b.size())) t.replace(p, a.size(), b);
    };
    if (e.path().filename() == "dem_granular_gas.yaml") sub("0.04713", "0.01");
    if (e.path().filename() == "rotating_sphere.yaml")
      sub("physics: {gravity: [0, 0, 0]}", "physics: {gravity: [0, 0, 0], balance_weight: false}");
    out.push_back({e.path().filename().string(), t});
  }
  std::sort(out.begin(), out.end(), [](const CaseFile& a, const CaseFile& b) { return a.name < b.name; });
  return out;
}

struct Outcome {
  int code = 0;         // as main(): 0 ok, 2 ConfigError, 3 DivergenceError, 4 ResourceError, 1 anything else
  std::string message;  // the error's text
  std::vector<std::string> keys;  // Config::keys_read() after the check (also when it failed)
};

// `lbdem check` on `text` (named `name`), in this process, on the host backend.
inline Outcome check_case(const std::string& text, const std::string& name) {
  Outcome o;
  std::optional<Config> cfg;
  try {
    cfg.emplace(Config::from_string(text, name));
    RunOptions opt;
    opt.backend = "cpu";
    opt.quiet = true;
    opt.validate_only = true;
    run_case(*cfg, opt);
  } catch (const ConfigError& e) {
    o = {2, e.what(), {}};
  } catch (const DivergenceError& e) {
    o = {3, e.what(), {}};
  } catch (const ResourceError& e) {
    o = {4, e.what(), {}};
  } catch (const std::exception& e) {
    o = {1, std::string("unexpected ") + typeid(e).name() + ": " + e.what(), {}};
  }
  if (cfg) o.keys = cfg->keys_read();
  return o;
}

// Dotted names in `msg` whose first part is one of `sections` (the file name
// is removed first): "particles.list[0].position", "dem.substeps".
inline std::vector<std::string> dotted_names(std::string msg, const std::string& source,
                                             const std::set<std::string>& sections) {
  for (std::size_t p = msg.find(source); p != std::string::npos; p = msg.find(source, p)) msg.erase(p, source.size());
  static const std::regex re(R"(([A-Za-z_][A-Za-z0-9_]*)(\[[0-9]+\])?(\.[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+\])?)+)");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(msg.begin(), msg.end(), re); it != std::sregex_iterator(); ++it) {
    const std::size_t at = static_cast<std::size_t>(it->position(0));
    if (at > 0 && (std::isalnum(static_cast<unsigned char>(msg[at - 1])) || msg[at - 1] == '.' || msg[at - 1] == '/'))
      continue;  // part of a path or a longer word
    if (sections.count((*it)[1].str())) out.push_back((*it)[0].str());
  }
  return out;
}

}  // namespace lbdem::test
