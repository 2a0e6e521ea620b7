// lbdem_bench_psm: speed against error of the PSM coupling.
//
//   lbdem_bench_psm sweep [--out FILE.json] [--d 4,6,8,...] [--tau 0.6] [--methods exact,table,linear]
//                   [--precisions fp64,fp32] [--collisions trt,bgk] [--variants nebb] [--weights nt]
//                   [--chi 0.5] [--re 0.2] [--magic 0.1875] [--tol 1e-7] [--backend host|cuda] [--dim 3]
//   lbdem_bench_psm suspension [--out FILE.json] [--n 256] [--phi 0.128] [--d 10] [--steps 200]
//
// sweep: fixed sphere in a simple cubic array (the first paper's Table 1
// test) for every combination; per row the drag coefficient K against
// Sangani & Acrivos (1982), the steps and wall time to the detected steady
// state, and MLUPS. suspension: coupled MLUPS of a periodic suspension
// against fluid-only MLUPS on the same grid.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cases/fixed_sphere.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "imb/fraction_table.hpp"

using namespace lbdem;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string t;
  while (std::getline(ss, t, ',')) if (!t.empty()) out.push_back(t);
  return out;
}

// First paper Table 1, Re_p = 0.2 column (relative error in %).
double paper_error(double d) {
  const double dl[8] = {4, 6, 8, 10, 16, 20, 30, 50};
  const double e[8] = {15.99, 6.953, 4.352, 2.868, 2.101, 1.367, 0.6503, 0.3335};
  for (int i = 0; i < 8; ++i) if (std::abs(dl[i] - d) < 1e-9) return e[i];
  return NAN;
}

int sweep(int argc, char** argv) {
  std::string out, ds = "4,6,8,10,16,20,30,50", taus = "0.6", methods = "exact", precs = "fp64", colls = "trt",
                   variants = "nebb", weights = "nt", backend = "auto";
  double chi = 0.5, re = 0.2, magic = 3.0 / 16.0, tol = 1e-7;
  int dim = 3;
  long max_steps = 2000000;
  bool verbose = false;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw ConfigError(k + ": missing value");
      return argv[++i];
    };
    if (k == "--out") out = next();
    else if (k == "--d") ds = next();
    else if (k == "--tau") taus = next();
    else if (k == "--methods") methods = next();
    else if (k == "--precisions") precs = next();
    else if (k == "--collisions") colls = next();
    else if (k == "--variants") variants = next();
    else if (k == "--weights") weights = next();
    else if (k == "--backend") backend = next();
    else if (k == "--chi") chi = std::stod(next());
    else if (k == "--re") re = std::stod(next());
    else if (k == "--magic") magic = std::stod(next());
    else if (k == "--tol") tol = std::stod(next());
    else if (k == "--dim") dim = std::stoi(next());
    else if (k == "--max-steps") max_steps = std::stol(next());
    else if (k == "-v") verbose = true;
    else throw ConfigError("unknown option " + k);
  }
  const Backend b = resolve_backend(backend);
  std::vector<imb::FractionTable> tables;
  tables.reserve(1);
  std::ostringstream js;
  js << "{\n  \"backend\": \"" << (b == Backend::Cuda ? "cuda" : "host") << "\",\n  \"chi\": " << chi
     << ",\n  \"re_target\": " << re << ",\n  \"rows\": [\n";
  std::printf("| d/l | method | prec | coll | variant | weight | tau | K | error %% | paper %% | Re_p | steps | time s | MLUPS | balance |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  bool first = true;
  for (const auto& dstr : split(ds))
    for (const auto& m : split(methods))
      for (const auto& pr : split(precs))
        for (const auto& co : split(colls))
          for (const auto& va : split(variants))
            for (const auto& we : split(weights))
              for (const auto& ts : split(taus)) {
                cases::FixedSphereSpec s;
                s.dim = dim;
                s.diameter = std::stod(dstr);
                s.chi = chi;
                s.re_p = re;
                s.tau = std::stod(ts);
                s.magic = magic;
                s.tolerance = tol;
                s.max_steps = max_steps;
                s.quiet = !verbose;
                s.precision = pr == "fp32" ? lbm::Precision::FP32 : lbm::Precision::FP64;
                s.collision = co == "bgk" ? lbm::CollisionKind::BGK : lbm::CollisionKind::TRT;
                s.variant = va == "super" ? imb::PsmVariant::Superposition : imb::PsmVariant::NEBB;
                s.weight = we == "eps" ? imb::PsmWeight::Linear : imb::PsmWeight::NobleTorczynski;
                s.method = m == "table" ? imb::FractionMethod::Table
                           : m == "linear" ? imb::FractionMethod::Linear
                                           : imb::FractionMethod::Exact;
                if (s.method == imb::FractionMethod::Table) {
                  if (tables.empty()) tables.push_back(imb::build_fraction_table(dim));
                  s.table = &tables.back();
                }
                const auto r = cases::run_fixed_sphere(s, b);
                std::printf("| %s | %s | %s | %s | %s | %s | %s | %.5f | %+.3f | %.3f | %.3f | %ld%s | %.2f | %.0f | %.5f |\n",
                            dstr.c_str(), m.c_str(), pr.c_str(), co.c_str(), va.c_str(), we.c_str(), ts.c_str(), r.K,
                            100 * r.rel_error, paper_error(s.diameter), r.re_p, r.steps, r.converged ? "" : "*",
                            r.seconds, r.mlups, r.mean_flux / r.mean_u - 1);
                std::fflush(stdout);
                js << (first ? "" : ",\n") << "    {\"d\": " << s.diameter << ", \"method\": \"" << m
                   << "\", \"precision\": \"" << pr << "\", \"collision\": \"" << co << "\", \"variant\": \"" << va
                   << "\", \"weight\": \"" << we << "\", \"tau\": " << s.tau << ", \"K\": " << r.K
                   << ", \"K_ref\": " << r.K_ref << ", \"error\": " << r.rel_error
                   << ", \"paper_error\": " << paper_error(s.diameter) / 100 << ", \"re_p\": " << r.re_p
                   << ", \"steps\": " << r.steps << ", \"converged\": " << (r.converged ? "true" : "false")
                   << ", \"seconds\": " << r.seconds << ", \"mlups\": " << r.mlups << "}";
                first = false;
              }
  js << "\n  ]\n}\n";
  if (!out.empty()) std::ofstream(out) << js.str();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "sweep";
    if (mode == "sweep") return sweep(argc, argv);
    std::fprintf(stderr, "usage: lbdem_bench_psm sweep|suspension [options]\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
