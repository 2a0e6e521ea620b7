#pragma once
// lbdem_bench_psm startup (bench/imb/startup_case.hpp): the command line.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "startup_case.hpp"

namespace lbdem::bench {

// lbdem_bench_psm startup: the CLI (bench_psm.cpp dispatches here). Lists are
// swept (diameter outer, ratio inner); one JSON line per sample to --out
// ("bench": "startup_curve") and one per run ("bench": "startup"), a table on stdout.
namespace startup_cli {

inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::string t;
  for (char ch : s) {
    if (ch == ',') {
      if (!t.empty()) out.push_back(t);
      t.clear();
    } else {
      t += ch;
    }
  }
  if (!t.empty()) out.push_back(t);
  return out;
}

inline std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// A number option's value: the whole string must parse, else a ConfigError naming the option.
inline double number(const std::string& key, const std::string& v) {
  std::size_t pos = 0;
  double x = 0;
  try {
    x = std::stod(v, &pos);
  } catch (const std::exception&) {
    pos = 0;
  }
  if (pos == 0 || pos != v.size()) throw ConfigError(key + " " + v + ": not a number");
  return x;
}

}  // namespace startup_cli

inline int startup_main(int argc, char** argv) {
  using namespace startup_cli;
  std::string out, ds = "6", rs = "2,8", magic = "auto", weight = "ntw", backend = "auto", prec = "fp64";
  StartupSpec base;
  bool curve = true;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw ConfigError(k + ": missing value");
      return argv[++i];
    };
    if (k == "--out") out = next();
    else if (k == "--diameter") ds = next();
    else if (k == "--ratio") rs = next();
    else if (k == "--tau") base.tau = number(k, next());
    else if (k == "--magic") magic = next();
    else if (k == "--weights") weight = next();
    else if (k == "--re") base.re = number(k, next());
    else if (k == "--box") base.box = number(k, next());
    else if (k == "--window") base.window = number(k, next());
    else if (k == "--settle") base.settle = number(k, next());
    else if (k == "--samples") base.samples = static_cast<int>(number(k, next()));
    else if (k == "--precision") prec = next();
    else if (k == "--backend") backend = next();
    else if (k == "--curve") curve = number(k, next()) != 0;
    else throw ConfigError("startup: unknown option " + k);
  }
  if (weight != "ntw" && weight != "nt") throw ConfigError("--weights " + weight + ": must be ntw or nt");
  base.weight = weight == "ntw" ? imb::PsmWeight::NobleTorczynskiWall : imb::PsmWeight::NobleTorczynski;
  base.precision = lbm::precision_from_string(prec);
  if (!(base.tau > 0.5)) throw ConfigError("--tau " + num(base.tau) + ": must be > 0.5");
  if (!(base.re > 0 && base.re <= 1)) throw ConfigError("--re " + num(base.re) + ": must be in (0, 1] (Stokes regime)");
  if (!(base.box >= 3)) throw ConfigError("--box " + num(base.box) + ": must be >= 3 (box edge in diameters)");
  if (!(base.window > 0 && base.window <= 0.5)) throw ConfigError("--window " + num(base.window) + ": must be in (0, 0.5]");
  if (!(base.settle > 0)) throw ConfigError("--settle " + num(base.settle) + ": must be > 0");
  if (!(base.samples >= 1)) throw ConfigError("--samples " + num(base.samples) + ": must be >= 1");
  if (magic != "auto" && !(number("--magic", magic) > 0)) throw ConfigError("--magic " + magic + ": must be > 0 or auto");
  for (const auto& x : split(ds))
    if (!(number("--diameter", x) >= 4)) throw ConfigError("--diameter " + x + ": must be >= 4 cells");
  for (const auto& x : split(rs)) {
    const double r = number("--ratio", x);
    if (!(r >= 1)) throw ConfigError("--ratio " + x + ": must be >= 1 (a sphere lighter than the fluid is outside what this case was checked for)");
  }
  const Backend b = resolve_backend(backend);
  std::printf("| d/l | rho_p/rho | L | phi | Lambda | steps | T end | RMS box | max box | RMS box r+1 | max box r+1 | "
              "window T | RMS unb. | max unb. | lab end | box | box r+1 | slip | Hasimoto | err %% | S&A | err %% | s | MLUPS |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  for (const auto& dstr : split(ds))
    for (const auto& rstr : split(rs)) {
      StartupSpec s = base;
      s.diameter = number("--diameter", dstr);
      s.ratio = number("--ratio", rstr);
      s.magic = magic == "auto" ? -1 : number("--magic", magic);
      const auto r = run_startup(s, b);
      const double eh = 100 * (r.terminal / r.hasimoto - 1), es = 100 * (r.terminal / r.sangani_acrivos - 1);
      std::printf("| %s | %s | %ld | %.5f | %.3g | %ld | %.1f | %.4f | %.4f | %.4f | %.4f | %.2f | %.4f | %.4f | %.5f | "
                  "%.5f | %.5f | %.5f | %.5f | %+.2f | %.5f | %+.2f | %.1f | %.1f |\n",
                  dstr.c_str(), rstr.c_str(), r.L, r.phi, r.magic, r.steps, r.T_end, r.rms_box, r.max_box,
                  r.rms_box_psm, r.max_box_psm, r.T_window, r.rms, r.max, r.lab_end, r.lab_box, r.lab_box_psm,
                  r.terminal, r.hasimoto, eh, r.sangani_acrivos, es, r.seconds, r.mlups);
      std::fflush(stdout);
      if (out.empty()) continue;
      std::ofstream o(out, std::ios::app);
      const std::string common = "\"device\": \"" + device_name(b) + "\", \"d\": " + num(s.diameter) +
                                 ", \"ratio\": " + num(s.ratio) + ", \"tau\": " + num(s.tau) + ", \"magic\": " +
                                 num(r.magic) + ", \"weight\": \"" + weight + "\", \"precision\": \"" + prec +
                                 "\", \"re\": " + num(s.re) + ", \"L\": " + std::to_string(r.L);
      if (curve)
        for (const auto& q : r.samples) {
          if (q.step == 0) continue;
          o << "{\"bench\": \"startup_curve\", " << common << ", \"step\": " << q.step << ", \"T\": " << num(q.T)
            << ", \"v\": " << num(q.v) << ", \"u\": " << num(q.u) << ", \"ref\": " << num(q.ref)
            << ", \"error\": " << num(q.u - q.ref) << ", \"box\": " << num(q.box) << ", \"error_box\": "
            << num(q.u - q.box) << ", \"u_psm\": " << num(q.u_psm) << ", \"box_psm\": " << num(q.box_psm)
            << ", \"error_box_psm\": " << num(q.u_psm - q.box_psm)
            << ", \"in_window\": " << (q.in_window ? "true" : "false") << "}\n";
        }
      o << "{\"bench\": \"startup\", " << common << ", \"phi\": " << num(r.phi) << ", \"t_nu\": " << num(r.t_nu)
        << ", \"F\": " << num(r.F) << ", \"u_T\": " << num(r.u_T) << ", \"steps\": " << r.steps
        << ", \"T_end\": " << num(r.T_end) << ", \"window_steps\": " << r.window_steps
        << ", \"T_window\": " << num(r.T_window) << ", \"rms_box\": " << num(r.rms_box)
        << ", \"max_box\": " << num(r.max_box) << ", \"rms_box_psm\": " << num(r.rms_box_psm)
        << ", \"max_box_psm\": " << num(r.max_box_psm) << ", \"rms\": " << num(r.rms) << ", \"max\": " << num(r.max)
        << ", \"v_end\": " << num(r.v_end) << ", \"lab_end\": " << num(r.lab_end) << ", \"lab_box\": "
        << num(r.lab_box) << ", \"lab_box_psm\": " << num(r.lab_box_psm) << ", \"J\": " << num(r.J)
        << ", \"terminal\": " << num(r.terminal) << ", \"hasimoto\": " << num(r.hasimoto)
        << ", \"sangani_acrivos\": " << num(r.sangani_acrivos) << ", \"error_hasimoto\": " << num(eh / 100)
        << ", \"error_sangani_acrivos\": " << num(es / 100) << ", \"late_change\": " << num(r.late_change)
        << ", \"seconds\": " << num(r.seconds) << ", \"cells\": " << r.cells << ", \"mlups\": " << num(r.mlups)
        << "}\n";
    }
  return 0;
}

}  // namespace lbdem::bench
