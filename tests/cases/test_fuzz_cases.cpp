// Fuzzing the case-file loader and the validation of every scene: the shipped
// case files mutated at random (fixed seed: the same cases every run) by
// deleting, duplicating and swapping lines, retyping values, inserting random
// bytes, huge numbers and deep nesting, and truncating. `lbdem check` must
// never crash: exit code 0, 2 (invalid input) or 4 (a memory refusal), and a
// refusal is one line naming the file or a key.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "case_mutation.hpp"
#include "run_lbdem.hpp"

namespace {

namespace fs = std::filesystem;
using lbdem::test::CaseFile;

std::vector<std::string> lines_of(const std::string& t) {
  std::vector<std::string> out;
  std::size_t s = 0;
  while (s <= t.size()) {
    const std::size_t e = t.find('\n', s);
    out.push_back(t.substr(s, e == std::string::npos ? std::string::npos : e - s));
    if (e == std::string::npos) break;
    s = e + 1;
  }
  return out;
}
std::string join(const std::vector<std::string>& v) {
  std::string t;
  for (const auto& l : v) t += l + "\n";
  return t;
}

class Mutator {
 public:
  explicit Mutator(std::uint64_t seed) : rng_(seed) {}
  std::size_t pick(std::size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }

  std::string mutate(const std::string& text, std::string& what) {
    auto lines = lines_of(text);
    const std::size_t i = pick(lines.size()), j = pick(lines.size());
    static const char* tokens[] = {"abc", "[1, 2]", "{a: 1}", "-1", "0", "1e308", "-1e308", "1e-308", ".nan", ".inf",
                                   "~", "''", "true", "99999999999999999999", "[", "}", "!!binary aGVsbG8=", "*x",
                                   "&a 1", "[0, 0, 0]", "[1e300, 1e300, 1e300]", "\"\\u200b\"", "- 1", "? a"};
    static const char* numbers[] = {"1e300", "-1e300", "1e15", "-1e15", "99999999999999999999", "1e-300", "0", "-0",
                                    "4294967296", "2147483648", "1000000", "0.5"};
    switch (pick(9)) {
      case 0:
        what = "delete line " + std::to_string(i);
        lines.erase(lines.begin() + static_cast<long>(i));
        break;
      case 1:
        what = "duplicate line " + std::to_string(i);
        lines.insert(lines.begin() + static_cast<long>(i), lines[i]);
        break;
      case 2: {
        const std::string tok = tokens[pick(std::size(tokens))];
        what = "retype line " + std::to_string(i) + " to " + tok;
        const auto c = lines[i].find(':');
        if (c != std::string::npos) lines[i] = lines[i].substr(0, c + 1) + " " + tok;
        else lines[i] += tok;
        break;
      }
      case 3: {
        std::string t = join(lines);
        const std::size_t at = pick(t.size() + 1), n = 1 + pick(16);
        std::string bytes;
        for (std::size_t k = 0; k < n; ++k) bytes += static_cast<char>(pick(256));
        what = "insert " + std::to_string(n) + " random bytes at " + std::to_string(at);
        return t.insert(at, bytes);
      }
      case 4: {
        // Replace the k-th number in the file.
        std::string t = join(lines);
        std::vector<std::pair<std::size_t, std::size_t>> nums;
        for (std::size_t p = 0; p < t.size();) {
          if (std::isdigit(static_cast<unsigned char>(t[p])) && (p == 0 || !std::isalnum(static_cast<unsigned char>(t[p - 1])))) {
            std::size_t e = p;
            while (e < t.size() && (std::isalnum(static_cast<unsigned char>(t[e])) || t[e] == '.' || t[e] == '-' || t[e] == '+')) ++e;
            nums.push_back({p, e - p});
            p = e;
          } else {
            ++p;
          }
        }
        if (nums.empty()) return t;
        const auto [p, n] = nums[pick(nums.size())];
        const std::string num = numbers[pick(std::size(numbers))];
        what = "number at " + std::to_string(p) + " -> " + num;
        return t.replace(p, n, num);
      }
      case 5: {
        const std::size_t depth = 10 + pick(5000);
        const bool map = pick(2) == 1;
        std::string nest;
        for (std::size_t k = 0; k < depth; ++k) nest += map ? "{a: " : "[";
        if (pick(2) == 1)
          for (std::size_t k = 0; k < depth; ++k) nest += map ? "}" : "]";
        what = "nesting " + std::to_string(depth) + (map ? " maps" : " lists") + " at line " + std::to_string(i);
        const auto c = lines[i].find(':');
        lines[i] = (c != std::string::npos ? lines[i].substr(0, c + 1) : lines[i] + ":") + " " + nest;
        break;
      }
      case 6:
        what = "swap lines " + std::to_string(i) + ", " + std::to_string(j);
        std::swap(lines[i], lines[j]);
        break;
      case 7: {
        std::string t = join(lines);
        const std::size_t at = pick(t.size() + 1);
        what = "truncate at " + std::to_string(at);
        return t.substr(0, at);
      }
      default: {
        std::string w1, w2;
        std::string t = mutate(mutate(join(lines), w1), w2);
        what = w1 + "; " + w2;
        return t;
      }
    }
    return join(lines);
  }

 private:
  std::mt19937_64 rng_;
};

// A refusal names the file (every message of the loader and of the scene
// checks starts with it) or a key of the case file.
void expect_clean_refusal(const lbdem::test::Outcome& o, const std::string& source) {
  EXPECT_FALSE(o.message.empty());
  EXPECT_EQ(o.message.find('\n'), std::string::npos) << o.message;
  const bool names_file = o.message.find(source) != std::string::npos;
  static const std::set<std::string> sections = {"scene", "units", "lattice", "precision", "streaming", "collision",
                                                 "fluid", "domain", "walls", "physics", "material", "particles",
                                                 "neighbours", "time", "output", "diagnostics", "geometry", "steady",
                                                 "psm", "dem", "channel", "taylor_green", "lid_driven_cavity",
                                                 "periodic_box"};
  const bool names_key = !lbdem::test::dotted_names(o.message, source, sections).empty() ||
                         o.message.find("key '") != std::string::npos;
  EXPECT_TRUE(names_file || names_key) << "names neither the file nor a key: " << o.message;
}

TEST(FuzzCases, MutatedShippedCasesNeverCrashTheCheck) {
  const auto files = lbdem::test::shipped_cases();
  ASSERT_GE(files.size(), 10u);
  // LBDEM_FUZZ_SEED and LBDEM_FUZZ_CASES run other or more cases by hand
  // (a longer search; LBDEM_FUZZ_DUMP=FILE keeps the case in progress); the
  // defaults are the test.
  const char* seed = std::getenv("LBDEM_FUZZ_SEED");
  const char* cases = std::getenv("LBDEM_FUZZ_CASES");
  const char* dump = std::getenv("LBDEM_FUZZ_DUMP");
  Mutator m(seed ? std::stoull(seed) : 20261124);
  const int kCases = cases ? std::stoi(cases) : 1500;
  int refused = 0, accepted = 0;
  for (int k = 0; k < kCases; ++k) {
    const CaseFile& f = files[static_cast<std::size_t>(k) % files.size()];
    std::string what;
    const std::string text = m.mutate(f.text, what);
    const std::string source = "fuzz/" + f.name;
    if (dump) std::ofstream(dump, std::ios::binary) << text;  // the case in progress, should it crash
    const auto o = lbdem::test::check_case(text, source);
    SCOPED_TRACE("case " + std::to_string(k) + ": " + f.name + ", " + what);
    ASSERT_TRUE(o.code == 0 || o.code == 2 || o.code == 4) << "exit code " << o.code << ": " << o.message << "\n"
                                                            << text.substr(0, 3000);
    if (o.code == 0) {
      ++accepted;
      continue;
    }
    ++refused;
    expect_clean_refusal(o, source);
  }
  EXPECT_GT(refused, kCases / 3);
  EXPECT_GT(accepted, 0);
}

// A sample through the real binary: the exit code, and nothing but one
// error line (and the backend note) on the terminal.
TEST(FuzzCases, SampleThroughTheBinary) {
  const auto files = lbdem::test::shipped_cases();
  const fs::path dir = fs::temp_directory_path() / ("lbdem_fuzz_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  Mutator m(7);
  for (int k = 0; k < 40; ++k) {
    const CaseFile& f = files[static_cast<std::size_t>(k) % files.size()];
    std::string what;
    const std::string text = m.mutate(f.text, what);
    const fs::path p = dir / f.name;
    std::ofstream(p, std::ios::binary) << text;
    const auto r = lbdem::test::run("check '" + p.string() + "'");
    SCOPED_TRACE(f.name + ", " + what);
    EXPECT_TRUE(r.code == 0 || r.code == 2 || r.code == 4) << r.code << ": " << r.out.substr(0, 2000);
    std::size_t lines = 0;
    // The memory table of a particle scene that passes (a head line naming
    // "device memory", then indented component lines) is not an error line,
    // nor is a log line ("[hh:mm:ss] ...": notes and warnings such as the
    // expected drag error of a particle scene).
    for (const auto& l : lines_of(r.out))
      if (!l.empty() && l.find("backend auto:") == std::string::npos && l.find(": device memory (") == std::string::npos &&
          l.rfind("  ", 0) != 0 && l.rfind("[", 0) != 0)
        ++lines;
    EXPECT_EQ(lines, 1u) << r.out.substr(0, 2000);
  }
  fs::remove_all(dir);
}

}  // namespace
