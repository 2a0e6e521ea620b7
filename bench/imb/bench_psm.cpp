// lbdem_bench_psm: speed against error of the PSM coupling.
//
//   lbdem_bench_psm sweep [--out FILE.json] [--d 4,6,8,...] [--tau 0.52] [--methods exact,table,linear]
//                   [--precisions fp64,fp32,fp16s,fp16c] [--collisions trt,bgk] [--variants nebb,nebbe,super] [--weights nt,eps]
//                   [--magic 1e-4 (or auto: by d/l and tau, imb::psm_magic_auto; auto*F: F times it)] [--offset 0.5,0,centre] [--re 0.2]
//                   [--chi 0.5 (<= 0.75, or a dense point of Zick & Homsy: 0.8685, 0.9508, 1)] [--tol 1e-5]
//                   [--start estimate|rest] [--check N] [--max-steps N] [--periods 0 (per axis; 0: as needed)]
//                   [--backend host|cuda] [--dim 3] [-v]
//   lbdem_bench_psm suspension [--out FILE.json] [--n 256 | --dims X,Y,Z] [--phi 0.128] [--d 10] [--steps 200]
//                   [--substeps N (default: fewest accepted)] [--tau 0.6] [--precision fp32|fp64|fp16s|fp16c] [--fraction exact|table|linear]
//                   [--pipeline auto|fused|mapped] [--backend host|cuda]
//   lbdem_bench_psm random [--out FILE.jsonl] [--n 3 (n^3 spheres)] [--d 8] [--phi 0.1,0.2,0.3] [--re 0.2]
//                   [--tau 0.8] [--magic auto] [--seeds 1] [--sweeps 200] [--min-gap 1] [--weights ntw] [--tol 1e-5]
//                   [--backend host|cuda]
//   lbdem_bench_psm brenner [--out FILE.jsonl] [--diameter 10] [--gaps 1,2,4,8,2d (cells; Nd: N diameters)]
//                           [--lubrication bench|engine (who adds the gap correction; default bench)]
//                   [--box 8 (W = H = box * d, a list)] [--height H/d (default: the box)] [--wall bb|psm] [--tau 0.8] [--magic auto] [--weights ntw] [--re 0.1]
//                   [--chi-ref 0.25] [--unbounded F_inf/F_St (skips its run)] [--tol 1e-5] [--max-steps N]
//                   [--precision fp64] [--backend host|cuda]
//   lbdem_bench_psm tube [--out FILE.jsonl] [--diameter 10] [--k 0.1,0.2,0.3] [--length 2 (tube length / D)]
//                   [--tau 0.8] [--magic auto] [--weights ntw] [--re 0.1] [--chi-ref 0.25] [--tol 1e-5]
//                   [--max-steps N] [--precision fp64] [--backend host|cuda]
//   lbdem_bench_psm startup [--out FILE.jsonl] [--diameter 6] [--ratio 2,8] [--box 6 (L = box * d)] [--re 0.2]
//                   [--tau 0.8] [--magic auto] [--weights ntw] [--window 0.25] [--settle 8] [--samples 40]
//                   [--curve 1] [--precision fp64] [--backend host|cuda]   (startup_case.hpp, startup_main.hpp)
//   lbdem_bench_psm drift [--dims 64,252,64] [--steps 100000] [--every 5000] [--tau 1.2386] [--d 10] [--phi 0.128]
//                   [--precision fp64] [--fraction table|exact] [--even-relaxation 0|1] [--backend host|cuda]
//
// --variants nebbe: NEBB with even relaxation (imb::PsmOptions::even_relaxation); --even-relaxation 1 the same
// in the drift run.
//
// sweep: fixed sphere in a simple cubic array (the first paper's Table 1
// test) for every combination; per row the drag coefficient K against
// Sangani & Acrivos (1982) (chi <= 0.75) or Zick & Homsy (1982) (their
// tabulated dense points, imb::sphere_array_K), the steps and wall time to the detected steady
// state, and MLUPS. suspension: coupled MLUPS of a periodic suspension
// against fluid-only MLUPS on the same grid.
#include <cmath>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "psm_plane_wall.hpp"
#include "random_array.hpp"
#include "startup_main.hpp"
#include "wall_cases.hpp"
#include "imb/fixed_sphere.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "core/buffer.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/drag_error.hpp"
#include "imb/fraction_table.hpp"
#include <algorithm>
#include <chrono>
#include <random>

using namespace lbdem;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string t;
  while (std::getline(ss, t, ',')) if (!t.empty()) out.push_back(t);
  return out;
}

// The value after option argv[i] (advances i).
std::string option_value(int argc, char** argv, int& i) {
  if (i + 1 >= argc) throw ConfigError(std::string(argv[i]) + ": missing value");
  return argv[++i];
}

// First paper Table 1, Re_p = 0.2 column (relative error in %); between its
// diameters (the dense array's d = chi L is not an integer) interpolated
// linearly in d/l; NaN outside d/l 4-50.
double paper_error(double d) {
  const double dl[8] = {4, 6, 8, 10, 16, 20, 30, 50};
  const double e[8] = {15.99, 6.953, 4.352, 2.868, 2.101, 1.367, 0.6503, 0.3335};
  for (int i = 0; i < 8; ++i) if (std::abs(dl[i] - d) < 1e-9) return e[i];
  for (int i = 0; i < 7; ++i)
    if (d > dl[i] && d < dl[i + 1]) return e[i] + (d - dl[i]) / (dl[i + 1] - dl[i]) * (e[i + 1] - e[i]);
  return NAN;
}

// JSON number (null for NaN / inf: JSON has neither).
std::string jnum(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

// The drag sweep. Every option that names a list is swept (outer to inner:
// d, method, precision, collision, variant, weight, tau, magic, offset, re).
// Rows are appended to --out after each run (the file is rewritten whole, so
// a run cut off by a time limit keeps the rows it finished).
//
// Defaults (bench/imb/NOTES.md, "Fixed-sphere drag"): tau 0.52, TRT Lambda
// 1e-4, NEBB, Noble-Torczynski B, exact fractions, fp64; sphere centre on a
// cell centre (offset 0.5: the first paper does not say where its sphere
// sits; "centre" puts it on a cell centre for every period: 0.5 for even L,
// 0 for odd L); Re_p = 0.2, the paper's (both references are Stokes flow;
// the inertial change of K at this Re_p is far below the bars, NOTES);
// start from the Stokes estimate; tolerance 1e-5 on the estimated remaining
// relative change of the drag.
int sweep(int argc, char** argv) {
  std::string out, ds = "4,6,8,10,16,20,30,50", taus = "0.52", methods = "exact", precs = "fp64", colls = "trt",
                   variants = "nebb", weights = "nt", backend = "auto", magics = "1e-4", offsets = "0.5", res = "0.2",
                   start = "estimate";
  double chi = 0.5, tol = 1e-5;
  int dim = 3;
  long max_steps = 4000000, check = 0;
  int periods = 0;
  bool verbose = false;
  double even_phi = 1.0;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&] { return option_value(argc, argv, i); };
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
    else if (k == "--re") res = next();
    else if (k == "--magic") magics = next();
    else if (k == "--offset") offsets = next();
    else if (k == "--start") start = next();
    else if (k == "--tol") tol = std::stod(next());
    else if (k == "--dim") dim = std::stoi(next());
    else if (k == "--max-steps") max_steps = std::stol(next());
    else if (k == "--check") check = std::stol(next());
    else if (k == "--periods") periods = std::stoi(next());
    else if (k == "--even") even_phi = std::stod(next());
    else if (k == "-v") verbose = true;
    else throw ConfigError("unknown option " + k);
  }
  if (start != "rest" && start != "estimate") throw ConfigError("--start " + start + ": must be rest or estimate");
  // The reference: Sangani & Acrivos to chi 0.75, Zick & Homsy's tabulated dense points above (3D).
  const char* reference = "";
  if (std::isnan(imb::sphere_array_K(chi, &reference)) || (chi > 0.75 && dim != 3)) {
    std::string points;
    for (const auto& p : imb::kZickHomsy)
      if (imb::zick_homsy_chi(p.phi) > 0.75)
        points += (points.empty() ? "" : ", ") + jnum(std::round(imb::zick_homsy_chi(p.phi) * 1e4) / 1e4);
    throw ConfigError("--chi " + jnum(chi) + ": must be in (0, 0.75] (Sangani & Acrivos's series) or, in 3D, within " +
                      jnum(imb::kZickHomsyChiTolerance) + " of a dense point tabulated by Zick & Homsy (1982): " +
                      points);
  }
  if (dim == 2) reference = "Sangani & Acrivos (1982), square arrays of cylinders";  // run_fixed_sphere's 2D reference
  const Backend b = resolve_backend(backend);
  std::vector<imb::FractionTable> tables;
  tables.reserve(1);
  std::ostringstream head;
  head << "{\n" << bench::json_header("lbdem_bench_psm sweep", bench::device_name(b), {}) << ",\n  \"backend\": \""
       << (b == Backend::Cuda ? "cuda" : "host") << "\",\n  \"chi\": " << chi
       << ",\n  \"tolerance\": " << tol << ",\n  \"start\": \"" << start
       << "\",\n  \"reference\": \"" << reference << ", Stokes flow\""
       << ",\n  \"paper\": \"first paper Table 1, Re_p = 0.2, against Fluent at the same Re_p\",\n  \"rows\": [\n";
  std::string rows;
  std::printf("# K against %s (Stokes); paper %% = first paper Table 1 (Re_p = 0.2; linear in d/l between its diameters); "
              "bar = half of it\n", reference);
  std::printf("| d/l | method | prec | coll | weight, operator | tau | Lambda | offset | K | error %% | paper %% | bar %% | Re_p | steps | time s | MLUPS | remaining |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& dstr : split(ds))
    for (const auto& m : split(methods))
      for (const auto& pr : split(precs))
        for (const auto& co : split(colls))
          for (const auto& va : split(variants))
            for (const auto& we : split(weights))
              for (const auto& ts : split(taus))
                for (const auto& ms : split(magics))
                  for (const auto& os : split(offsets))
                    for (const auto& rs : split(res)) {
                      imb::FixedSphereSpec s;
                      s.dim = dim;
                      s.diameter = std::stod(dstr);
                      s.chi = chi;
                      s.re_p = std::stod(rs);
                      s.tau = std::stod(ts);
                      // "auto": Lambda by d/l and tau (imb::psm_magic_auto, bench/imb/NOTES.md).
                      // "auto*F": F times that (the table's slope, scripts/drag_map.sh gpu-lam).
                      s.magic = ms == "auto"                ? imb::psm_magic_auto(s.diameter, s.tau)
                                : ms.rfind("auto*", 0) == 0 ? imb::psm_magic_auto(s.diameter, s.tau) * std::stod(ms.substr(5))
                                                            : std::stod(ms);
                      // "centre": the sphere centre on a cell centre (L/2 is one for odd L, a corner for even L).
                      s.offset = os == "centre" ? (std::lround(s.diameter / chi) % 2 == 0 ? 0.5 : 0.0) : std::stod(os);
                      // fp32 round-off floors the drag's step-to-step change near 1e-6, 16-bit storage near 1e-4.
                      s.tolerance = pr == "fp64" ? tol : std::max(tol, pr == "fp32" ? 1e-5 : 5e-4);
                      s.max_steps = max_steps;
                      s.check_every = check;
                      s.periods = periods;
                      s.start = start == "rest" ? imb::FixedSphereSpec::Start::Rest
                                                : imb::FixedSphereSpec::Start::Estimate;
                      s.quiet = !verbose;
                      s.precision = lbm::precision_from_string(pr);
                      s.collision = co == "bgk" ? lbm::CollisionKind::BGK : lbm::CollisionKind::TRT;
                      s.variant = va == "super" ? imb::PsmVariant::Superposition : imb::PsmVariant::NEBB;
                      s.even_relaxation = va == "nebbe" ? even_phi : 0.0;
                      s.weight = we == "eps"    ? imb::PsmWeight::Linear
                                 : we == "ntw" ? imb::PsmWeight::NobleTorczynskiWall
                                               : imb::PsmWeight::NobleTorczynski;
                      s.method = m == "table" ? imb::FractionMethod::Table
                                 : m == "linear" ? imb::FractionMethod::Linear
                                                 : imb::FractionMethod::Exact;
                      if (s.method == imb::FractionMethod::Table) {
                        if (tables.empty()) tables.push_back(imb::build_fraction_table(dim));
                        s.table = &tables.back();
                      }
                      // BGK: the solver's Lambda is (tau - 1/2)^2 whatever --magic says.
                      const double lam = s.collision == lbm::CollisionKind::BGK ? (s.tau - 0.5) * (s.tau - 0.5) : s.magic;
                      const auto r = imb::run_fixed_sphere(s, b);
                      const double paper = paper_error(s.diameter);
                      std::printf("| %s | %s | %s | %s | %s | %s | %.2g | %g | %.5f | %+.3f | %.3f | %.3f%s | %.4f | %ld%s | %.2f | %.0f | %.1e |\n",
                                  dstr.c_str(), m.c_str(), pr.c_str(), co.c_str(), (we + ", " + va).c_str(), ts.c_str(), lam,
                                  s.offset, r.K, 100 * r.rel_error, paper, paper / 2,
                                  std::isfinite(paper) ? (std::abs(100 * r.rel_error) <= paper / 2 ? " ok" : " MISSED") : "",
                                  r.re_p, r.steps, r.converged ? "" : "*", r.seconds, r.mlups, r.remaining);
                      std::fflush(stdout);
                      std::ostringstream row;
                      row << (rows.empty() ? "" : ",\n") << "    {\"d\": " << jnum(s.diameter) << ", \"method\": \"" << m
                          << "\", \"precision\": \"" << pr << "\", \"collision\": \"" << co << "\", \"variant\": \""
                          << va << "\", \"weight\": \"" << we << "\", \"tau\": " << s.tau << ", \"magic\": " << jnum(lam)
                          << ", \"chi\": " << jnum(s.diameter / double(std::lround(s.diameter / chi)))
                          << ", \"offset\": " << s.offset << ", \"re_target\": " << s.re_p << ", \"K\": " << jnum(r.K)
                          << ", \"K_ref\": " << jnum(r.K_ref) << ", \"error\": " << jnum(r.rel_error)
                          << ", \"paper_error\": " << jnum(paper / 100) << ", \"re_p\": " << jnum(r.re_p)
                          << ", \"steps\": " << r.steps << ", \"converged\": " << (r.converged ? "true" : "false")
                          << ", \"remaining\": " << jnum(r.remaining) << ", \"seconds\": " << jnum(r.seconds)
                          << ", \"mlups\": " << jnum(r.mlups) << ", \"cells\": " << r.cells
                          << ", \"flux_over_u\": " << jnum(r.mean_flux / r.mean_u) << "}";
                      rows += row.str();
                      if (!out.empty()) std::ofstream(out) << head.str() << rows << "\n  ]\n}\n";
                    }
  if (!out.empty()) std::ofstream(out) << head.str() << rows << "\n  ]\n}\n";
  return 0;
}

// Plane PSM walls (psm_plane_wall.hpp): the effective wall position against
// tau, Lambda, the wall cell's solid fraction and the weighting. One JSON row
// per combination; a table on stdout.
int plane_wall(int argc, char** argv) {
  std::string out, taus = "0.505,0.52,0.55,0.6,0.7,0.8,1.0", magics = "1e-4", epss = "0.1,0.3,0.5,0.7,0.9",
                   flows = "poiseuille,couette", weights = "nt";
  double gap = 16;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&] { return option_value(argc, argv, i); };
    if (k == "--out") out = next();
    else if (k == "--tau") taus = next();
    else if (k == "--magic") magics = next();
    else if (k == "--eps") epss = next();
    else if (k == "--flows") flows = next();
    else if (k == "--weights") weights = next();
    else if (k == "--gap") gap = std::stod(next());
    else throw ConfigError("unknown option " + k);
  }
  std::string rows;
  std::printf("| flow | weight | tau | Lambda | eps | delta lo | delta hi | delta | steps |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& fl : split(flows))
    for (const auto& we : split(weights))
      for (const auto& ts : split(taus))
        for (const auto& ms : split(magics))
          for (const auto& es : split(epss)) {
            bench::PlaneWallSpec s;
            s.couette = fl == "couette";
            s.tau = std::stod(ts);
            s.magic = std::stod(ms);
            s.wall_eps = std::stod(es);
            s.gap = gap;
            if (we == "eps") s.weight = [](double e, double) { return e; };
            else if (we == "ntw")
              s.weight = [tau = s.tau](double e, double) {
                return imb::psm_weight(e, imb::psm_wall_weight_t(tau), imb::PsmWeight::NobleTorczynski);
              };
            else if (we.rfind("t=", 0) == 0) {  // NT form with tau - 1/2 replaced by a given t
              const double t = std::stod(we.substr(2));
              s.weight = [t](double e, double) { return imb::psm_weight(e, t, imb::PsmWeight::NobleTorczynski); };
            } else if (we.rfind("c=", 0) == 0) {  // B = min(1, eps t / ((1 - eps) + c t)), t = tau - 1/2
              const double cc = std::stod(we.substr(2));
              s.weight = [cc](double e, double t) { return std::min(1.0, e * t / ((1.0 - e) + cc * t)); };
            } else if (we != "nt") throw ConfigError("--weights " + we + ": must be nt, ntw, eps or t=VALUE");
            const auto r = bench::run_plane_wall(s);
            std::printf("| %s | %s | %s | %.3g | %s | %+.5f | %+.5f | %+.5f | %ld%s |\n", fl.c_str(), we.c_str(), ts.c_str(),
                        s.magic, es.c_str(), r.delta_lo, r.delta_hi, r.delta, r.steps, r.converged ? "" : "*");
            std::fflush(stdout);
            std::ostringstream row;
            row << (rows.empty() ? "" : ",\n") << "    {\"flow\": \"" << fl << "\", \"weight\": \"" << we
                << "\", \"tau\": " << s.tau << ", \"magic\": " << jnum(s.magic) << ", \"eps\": " << s.wall_eps
                << ", \"delta\": " << jnum(r.delta) << ", \"delta_lo\": " << jnum(r.delta_lo)
                << ", \"delta_hi\": " << jnum(r.delta_hi) << ", \"steps\": " << r.steps
                << ", \"converged\": " << (r.converged ? "true" : "false") << "}";
            rows += row.str();
          }
  if (!out.empty())
    std::ofstream(out) << "{\n" << bench::json_header("lbdem_bench_psm wall", "host", {}) << ",\n  \"gap\": " << gap
                       << ",\n  \"rows\": [\n" << rows << "\n  ]\n}\n";
  return 0;
}

double wall() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// Coupled PSM-DEM step of a periodic suspension against the fluid-only step on
// the same grid (first paper Table 2: solid fraction 0.128, d/l = 10).
int suspension(int argc, char** argv) {
  std::string out, backend = "auto", prec = "fp32", fraction = "exact", pipeline = "auto";
  long n = 256, steps = 200;
  std::array<long, 3> dims{0, 0, 0};  // --dims X,Y,Z: a box instead of the cube n^3
  double phi = 0.128, d = 10, tau = 0.6;
  int substeps = 0;  // 0: the fewest that check_coupled_setup accepts (t_c / 50 per sub-step)
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&] { return option_value(argc, argv, i); };
    if (k == "--out") out = next();
    else if (k == "--n") n = std::stol(next());
    else if (k == "--dims") {
      const std::string v = next();
      if (std::sscanf(v.c_str(), "%ld,%ld,%ld", &dims[0], &dims[1], &dims[2]) != 3 || dims[0] < 1 || dims[1] < 1 || dims[2] < 1)
        throw ConfigError("--dims " + v + ": give three positive cell counts X,Y,Z");
    }
    else if (k == "--steps") steps = std::stol(next());
    else if (k == "--phi") phi = std::stod(next());
    else if (k == "--d") d = std::stod(next());
    else if (k == "--substeps") substeps = std::stoi(next());
    else if (k == "--tau") tau = std::stod(next());
    else if (k == "--precision") prec = next();
    else if (k == "--fraction") fraction = next();
    else if (k == "--pipeline") pipeline = next();
    else if (k == "--backend") backend = next();
    else throw ConfigError("unknown option " + k);
  }
  const Backend b = resolve_backend(backend);
  lbm::LbmSetup s;
  s.lattice = lbm::LatticeKind::D3Q19;
  s.precision = lbm::precision_from_string(prec);
  s.collision = lbm::CollisionKind::TRT;
  s.tau = tau;
  s.magic = 1e-3;
  if (dims[0] == 0) dims = {n, n, n};
  s.domain.global = s.domain.local = {dims[0], dims[1], dims[2]};
  dem::RandomPackingSpec rs;
  rs.hi = {double(dims[0]), double(dims[1]), double(dims[2])};
  rs.solid_fraction = phi;
  rs.r_min = rs.r_max = 0.5 * d;
  rs.density = 692.3;  // first paper Table 2
  rs.seed = 11;
  dem::HostParticles hp = dem::random_packing(rs);
  const std::array<double, 3> g{0, -4.704e-7, 0};  // first paper Table 2 (lattice units)
  const auto N = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
  s.body_force = imb::balancing_body_force(hp, 3, g, 1.0, double(N));
  const double cells = double(N);
  const double bw = bench::copy_bandwidth(b, b == Backend::Cuda ? std::size_t(2) << 30 : std::size_t(1) << 28);

  // Fluid only.
  double fluid_mlups = 0, bytes_cell = 0;
  {
    auto fl = lbm::make_lbm_solver(s, b);
    fl->initialize(std::vector<std::uint8_t>(N, 0), std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
    bytes_cell = fl->bytes_per_cell_step();
    fl->step(10);
    fl->synchronize();
    const double t0 = wall();
    fl->step(steps);
    fl->synchronize();
    fluid_mlups = cells * steps / (wall() - t0) / 1e6;
  }
  // Coupled.
  auto fl = lbm::make_lbm_solver(s, b);
  fl->initialize(std::vector<std::uint8_t>(N, 0), std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {double(dims[0]), double(dims[1]), double(dims[2])};
  dp.periodic = {true, true, true};
  dp.material.stiffness = 17892;  // first paper Table 2
  dp.material.restitution = 0.9;
  dp.gravity = {g[0], g[1], g[2]};
  dp.external_forcing = true;
  dp.friction = true;
  dp.skin = 0.1 * d;
  imb::CoupledParams cp;
  cp.gravity = g;
  if (substeps <= 0) substeps = imb::coupled_scales(s, dp, hp, cp).min_substeps;
  dp.dt = 1.0 / substeps;
  cp.dem_substeps = substeps;
  imb::check_coupled_setup(s, dp, hp, cp);  // the same refusals a case file gets
  dem::DemSystem dem(Exec(b), dp, hp);
  cp.psm.map.method = fraction == "table" ? imb::FractionMethod::Table
                      : fraction == "linear" ? imb::FractionMethod::Linear : imb::FractionMethod::Exact;
  imb::FractionTable table;
  if (cp.psm.map.method == imb::FractionMethod::Table) {
    table = imb::build_fraction_table(3);
    cp.psm.map.table = &table;
    cp.psm.map.table_in_constant = false;
  }
  cp.psm.map.max_radius = 0.5 * d;
  if (pipeline != "auto" && pipeline != "fused" && pipeline != "mapped")
    throw ConfigError("--pipeline " + pipeline + ": must be auto, fused or mapped");
  cp.psm.pipeline = pipeline == "fused" ? imb::PsmPipeline::Fused
                    : pipeline == "mapped" ? imb::PsmPipeline::Mapped : imb::PsmPipeline::Auto;
  imb::CoupledSolver cs(*fl, dem, cp);
  const std::string used = imb::to_string(cs.coupling().pipeline());
  cs.advance(10);
  fl->synchronize();
  const double t0 = wall();
  cs.advance(steps);
  fl->synchronize();
  const double coupled_s = wall() - t0;
  const double coupled_mlups = cells * steps / coupled_s / 1e6;
  // Phase split of the coupled step: map alone, PSM fluid step alone, DEM alone.
  auto time_of = [&](auto&& f) {
    fl->synchronize();
    const double a = wall();
    for (long i = 0; i < 20; ++i) f();
    fl->synchronize();
    return (wall() - a) / 20;
  };
  const double t_dem = time_of([&] { dem.advance(substeps); });
  const double t_map = time_of([&] { cs.coupling().map(cs.particle_view(), cp.psm, false); });
  Buffer<double> f6(b, 6 * static_cast<Index>(hp.size()));
  const double t_psm = time_of([&] { cs.coupling().step(cs.particle_view(), cp.psm, f6.data()); });
  const double t_fluid = time_of([&] { fl->step(1); });
  const auto d0 = fl->diagnostics();
  const double frac_fluid = fluid_mlups * 1e6 * bytes_cell / bw;
  std::printf("suspension %ldx%ldx%ld, %ld particles d/l=%g phi=%.3f, %s, %s fractions, %s pipeline, %d DEM sub-steps:\n", dims[0], dims[1], dims[2],
              static_cast<long>(hp.size()), d, phi, prec.c_str(), fraction.c_str(), used.c_str(), substeps);
  std::printf("  copy bandwidth %.1f GB/s; fluid-only %.0f MLUPS (%.1f%% of copy); coupled %.0f MLUPS = %.1f%% of "
              "fluid-only; DEM %.3f ms/step; finite %d\n",
              bw / 1e9, fluid_mlups, 100 * frac_fluid, coupled_mlups, 100 * coupled_mlups / fluid_mlups, 1e3 * t_dem,
              d0.finite ? 1 : 0);
  std::printf("  per step: map %.3f ms, PSM fluid step + gather %.3f ms, plain fluid step %.3f ms, DEM %.3f ms\n",
              1e3 * t_map, 1e3 * t_psm, 1e3 * t_fluid, 1e3 * t_dem);
  if (!out.empty()) {
    std::ofstream js(out);
    js << "{\n" << bench::json_header("lbdem_bench_psm suspension", bench::device_name(b), {{to_string(b), bw}})
       << ",\n  \"backend\": \"" << (b == Backend::Cuda ? "cuda" : "host") << "\",\n  \"n\": " << n << ",\n  \"dims\": [" << dims[0] << ", " << dims[1] << ", " << dims[2] << "]"
       << ",\n  \"tau\": " << tau
       << ",\n  \"particles\": " << hp.size() << ",\n  \"d\": " << d << ",\n  \"phi\": " << phi
       << ",\n  \"precision\": \"" << prec << "\",\n  \"fraction\": \"" << fraction << "\",\n  \"pipeline\": \"" << used << "\",\n  \"substeps\": " << substeps << ",\n  \"steps\": " << steps
       << ",\n  \"fluid_mlups\": " << fluid_mlups
       << ",\n  \"fluid_fraction_of_copy\": " << frac_fluid << ",\n  \"coupled_mlups\": " << coupled_mlups
       << ",\n  \"coupled_over_fluid\": " << coupled_mlups / fluid_mlups << ",\n  \"dem_seconds_per_step\": "
       << t_dem << ",\n  \"map_seconds\": " << t_map << ",\n  \"psm_step_seconds\": " << t_psm
       << ",\n  \"fluid_step_seconds\": " << t_fluid << ",\n  \"fluid_finite\": " << (d0.finite ? "true" : "false") << "\n}\n";
  }
  return 0;
}

// Mean fluid density and superficial velocity of a weight-balanced periodic
// suspension over a long run (imb/psm.hpp, "Why NEBB keeps only the odd part
// of Eq. 2"): the shipped 3D suspension's physics (first paper Table 2: d/l
// 10, solid fraction 0.128, density ratio 692.3, g = 4.704e-7, random speeds
// 5e-3; tau 1.2386, Lambda auto, the wall-rule weighting, NEBB, table
// fractions) in a given box. One JSON line per sample: step, the mean fluid
// density sum (1 - eps) rho / sum (1 - eps), the mean density (conserved) and
// the superficial velocity sum (1 - eps) u / cells along -g. The drift is the
// change of the fluid density from the sample at step `every` on.
int drift(int argc, char** argv) {
  std::string backend = "auto", prec = "fp64", fraction = "table";
  std::array<long, 3> dims{64, 252, 64};  // the eighth box (cases/suspension/suspension_3d_eighth.yaml)
  long steps = 100000, every = 5000;
  double phi = 0.128, d = 10, tau = 1.2386;
  double even = 0;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&] { return option_value(argc, argv, i); };
    if (k == "--dims") {
      const std::string v = next();
      if (std::sscanf(v.c_str(), "%ld,%ld,%ld", &dims[0], &dims[1], &dims[2]) != 3 || dims[0] < 1 || dims[1] < 1 || dims[2] < 1)
        throw ConfigError("--dims " + v + ": give three positive cell counts X,Y,Z");
    } else if (k == "--steps") steps = std::stol(next());
    else if (k == "--every") every = std::max(1L, std::stol(next()));
    else if (k == "--phi") phi = std::stod(next());
    else if (k == "--d") d = std::stod(next());
    else if (k == "--tau") tau = std::stod(next());
    else if (k == "--precision") prec = next();
    else if (k == "--fraction") fraction = next();
    else if (k == "--even-relaxation") even = std::stod(next());
    else if (k == "--backend") backend = next();
    else throw ConfigError("unknown option " + k);
  }
  const Backend b = resolve_backend(backend);
  lbm::LbmSetup s;
  s.lattice = lbm::LatticeKind::D3Q19;
  s.precision = lbm::precision_from_string(prec);
  s.collision = lbm::CollisionKind::TRT;
  s.tau = tau;
  s.magic = imb::psm_magic_auto(d, tau);
  s.domain.global = s.domain.local = {dims[0], dims[1], dims[2]};
  dem::RandomPackingSpec rs;
  rs.hi = {double(dims[0]), double(dims[1]), double(dims[2])};
  rs.solid_fraction = phi;
  rs.r_min = rs.r_max = 0.5 * d;
  rs.density = 692.3;
  rs.seed = 1;
  dem::HostParticles hp = dem::random_packing(rs);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (auto& v : hp.v) {  // random directions, speed 5e-3 (the shipped case's random_speed)
    Vec3d e{U(rng), U(rng), U(rng)};
    const double n = std::sqrt(dot(e, e));
    v = (5e-3 / std::max(n, 1e-12)) * e;
  }
  const std::array<double, 3> g{0, -4.704e-7, 0};
  const auto N = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
  s.body_force = imb::balancing_body_force(hp, 3, g, 1.0, double(N));
  auto fl = lbm::make_lbm_solver(s, b);
  fl->initialize(std::vector<std::uint8_t>(N, 0), std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {double(dims[0]), double(dims[1]), double(dims[2])};
  dp.periodic = {true, true, true};
  dp.material.stiffness = 17892;
  dp.material.restitution = 0.9;
  dp.gravity = {g[0], g[1], g[2]};
  dp.external_forcing = true;
  dp.friction = true;
  dp.skin = 0.1 * d;
  imb::CoupledParams cp;
  cp.gravity = g;
  cp.dem_substeps = 10;
  dp.dt = 1.0 / cp.dem_substeps;
  cp.psm.weight = imb::PsmWeight::NobleTorczynskiWall;
  cp.psm.variant = imb::PsmVariant::NEBB;
  cp.psm.even_relaxation = even;
  cp.psm.map.method = fraction == "exact" ? imb::FractionMethod::Exact : imb::FractionMethod::Table;
  imb::FractionTable table;
  if (cp.psm.map.method == imb::FractionMethod::Table) {
    table = imb::build_fraction_table(3);
    cp.psm.map.table = &table;
  }
  cp.psm.map.max_radius = 0.5 * d;
  imb::check_coupled_setup(s, dp, hp, cp);
  dem::DemSystem dem(Exec(b), dp, hp);
  imb::CoupledSolver cs(*fl, dem, cp);
  std::printf("{\"mode\": \"drift\", \"device\": \"%s\", \"dims\": [%ld, %ld, %ld], \"particles\": %ld, \"d\": %g, "
              "\"tau\": %.6g, \"magic\": %.6g, \"precision\": \"%s\", \"fraction\": \"%s\", \"pipeline\": \"%s\", \"even_relaxation\": %g}\n",
              bench::device_name(b).c_str(), dims[0], dims[1], dims[2], static_cast<long>(hp.size()), d, tau, s.magic,
              prec.c_str(), fraction.c_str(), imb::to_string(cs.coupling().pipeline()),
              even);
  double first = 0;
  const double t0 = wall();
  std::vector<double> ts, rv, uv;  // samples from step `every` on (the trend fit)
  for (long n = 0; n <= steps; n += every) {
    if (n > 0) cs.advance(every);
    std::vector<double> rho, u;
    fl->macroscopic(rho, u);
    const auto eps = cs.solid_fraction_host();
    double fm = 0, fv = 0, m = 0, us = 0;
    for (std::size_t c = 0; c < N; ++c) {
      const double w = 1.0 - std::min(1.0, eps[c]);
      fm += w * rho[c];
      fv += w;
      m += rho[c];
      us += w * u[3 * c + 1];
    }
    if (n == every) first = fm / fv;  // after the start-up (the pressure field forms in the first steps)
    if (n >= every) {
      ts.push_back(double(n));
      rv.push_back(fm / fv);
      uv.push_back(-us / double(N));
    }
    std::printf("{\"step\": %ld, \"fluid_rho\": %.15f, \"drift\": %.3e, \"mean_rho\": %.15f, \"superficial_u\": %.6e, "
                "\"seconds\": %.1f}\n",
                n, fm / fv, n >= every ? fm / fv - first : 0.0, m / double(N), -us / double(N), wall() - t0);
    std::fflush(stdout);
  }
  // The fluid density moves with the particles (the covered cells sample the
  // flow's pressure field, which the moving particles stir), so one sample
  // against another mixes that noise with a drift. The trend: the least-squares
  // slope of the samples from step `every` on, times 1e5 steps, with its
  // standard error (residuals taken as independent: an estimate, the noise is
  // correlated over ~10^3 steps), and the residuals' RMS; likewise for the
  // superficial velocity (relative to its mean).
  auto fit = [&](const std::vector<double>& y, double& slope, double& se, double& rms, double& mean) {
    const double n = double(y.size());
    double tm = 0, ym = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      tm += ts[i] / n;
      ym += y[i] / n;
    }
    double stt = 0, sty = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      stt += (ts[i] - tm) * (ts[i] - tm);
      sty += (ts[i] - tm) * (y[i] - ym);
    }
    slope = stt > 0 ? sty / stt : 0.0;
    double ss = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      const double r = y[i] - ym - slope * (ts[i] - tm);
      ss += r * r;
    }
    rms = std::sqrt(ss / std::max(1.0, n));
    se = n > 2 && stt > 0 ? std::sqrt(ss / (n - 2) / stt) : 0.0;
    mean = ym;
  };
  if (ts.size() >= 3) {
    double a, ase, arms, am, b, bse, brms, bm;
    fit(rv, a, ase, arms, am);
    fit(uv, b, bse, brms, bm);
    std::printf("{\"trend\": \"fluid_rho\", \"from_step\": %ld, \"samples\": %zu, \"per_1e5_steps\": %.3e, "
                "\"stderr_per_1e5\": %.2e, \"residual_rms\": %.2e, \"superficial_u_mean\": %.6e, "
                "\"superficial_u_per_1e5_rel\": %.3e, \"superficial_u_stderr_rel\": %.2e, \"superficial_u_rms_rel\": %.2e}\n",
                every, ts.size(), a * 1e5, ase * 1e5, arms, bm, b * 1e5 / std::abs(bm), bse * 1e5 / std::abs(bm),
                brms / std::abs(bm));
  }
  return 0;
}

}  // namespace

// Random arrays (random_array.hpp): F against Beetstra et al. (2007) and
// Tenneti et al. (2011), one JSON line per run (appended to --out) and a table.
int random_arrays(int argc, char** argv) {
  std::string out, phis = "0.1,0.2,0.3", res = "0.2", taus = "0.8", magic = "auto", seeds = "1", weights = "ntw",
                   ds = "8", backend = "auto";
  bench::RandomArraySpec base;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&] { return option_value(argc, argv, i); };
    if (k == "--out") out = next();
    else if (k == "--n") base.n = std::stoi(next());
    else if (k == "--d") ds = next();
    else if (k == "--phi") phis = next();
    else if (k == "--re") res = next();
    else if (k == "--tau") taus = next();
    else if (k == "--magic") magic = next();
    else if (k == "--seeds") seeds = next();
    else if (k == "--sweeps") base.sweeps = std::stoi(next());
    else if (k == "--min-gap") base.min_gap = std::stod(next());
    else if (k == "--weights") weights = next();
    else if (k == "--tol") base.tolerance = std::stod(next());
    else if (k == "--max-steps") base.max_steps = std::stol(next());
    else if (k == "--backend") backend = next();
    else throw ConfigError("random: unknown option " + k);
  }
  const Backend b = resolve_backend(backend);
  std::printf("| d/l | phi | tau | Lambda | weight | seed | Re | F | Beetstra | err %% | Tenneti | err %% | L | min gap | steps | s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& dstr : split(ds))
    for (const auto& ph : split(phis))
      for (const auto& rs : split(res))
        for (const auto& ts : split(taus))
          for (const auto& we : split(weights))
            for (const auto& sd : split(seeds)) {
              bench::RandomArraySpec s = base;
              s.diameter = std::stod(dstr);
              s.phi = std::stod(ph);
              s.re = std::stod(rs);
              s.tau = std::stod(ts);
              s.magic = magic == "auto" ? -1.0 : std::stod(magic);
              s.seed = std::stoull(sd);
              if (we != "ntw" && we != "nt") throw ConfigError("--weights " + we + ": must be ntw or nt");
              s.weight = we == "ntw" ? imb::PsmWeight::NobleTorczynskiWall : imb::PsmWeight::NobleTorczynski;
              bench::RandomArrayResult r;
              try {
                r = bench::run_random_array(s, b);
              } catch (const DivergenceError& e) {  // one run's divergence does not end the sweep
                std::printf("| %s | %s | %s | diverged: %s |\n", dstr.c_str(), ph.c_str(), ts.c_str(), e.what());
                continue;
              }
              const double eb = 100 * (r.F / r.beetstra - 1), et = 100 * (r.F / r.tenneti - 1);
              std::printf("| %s | %.4f | %s | %.3g | %s | %s | %.3f | %.4f | %.4f | %+.2f | %.4f | %+.2f | %.0f | %.2f | %ld%s | %.1f |\n",
                          dstr.c_str(), r.phi, ts.c_str(), r.magic, we.c_str(), sd.c_str(), r.re, r.F, r.beetstra, eb,
                          r.tenneti, et, r.L, r.min_surface_gap, r.steps, r.converged ? "" : "*", r.seconds);
              std::fflush(stdout);
              if (!out.empty()) {
                std::ofstream o(out, std::ios::app);
                o << "{\"bench\": \"random_array\", \"device\": \"" << bench::device_name(b) << "\", \"n\": " << s.n
                  << ", \"d\": " << jnum(s.diameter) << ", \"phi\": " << jnum(r.phi) << ", \"tau\": " << jnum(s.tau)
                  << ", \"magic\": " << jnum(r.magic) << ", \"weight\": \"" << we << "\", \"seed\": " << s.seed
                  << ", \"re\": " << jnum(r.re) << ", \"F\": " << jnum(r.F) << ", \"beetstra\": " << jnum(r.beetstra)
                  << ", \"tenneti\": " << jnum(r.tenneti) << ", \"L\": " << jnum(r.L)
                  << ", \"min_gap\": " << jnum(r.min_surface_gap) << ", \"steps\": " << r.steps
                  << ", \"converged\": " << (r.converged ? "true" : "false") << ", \"remaining\": " << jnum(r.remaining)
                  << ", \"seconds\": " << jnum(r.seconds) << ", \"mlups\": " << jnum(r.mlups) << "}\n";
              }
            }
  return 0;
}


// Walls (wall_cases.hpp): a sphere moving toward a plane wall against
// Brenner (1961), a sphere moving along the axis of a tube against Haberman &
// Sayre (1958). One JSON line per run (appended to --out) and a table. Both
// drags are divided by the same sphere's unbounded drag (unbounded_factor:
// its simple-cubic-array K over Sangani & Acrivos's, at --chi-ref), so what
// is left is the wall's share; the raw ratio to Stokes's drag is printed too.
int wall_cases(const std::string& mode, int argc, char** argv) {
  std::string out, ds = "10", gaps = "1,2,4,8,2d", boxes = "8", ks = "0.1,0.2,0.3", magic = "auto", weight = "ntw",
                   backend = "auto", prec = "fp64";
  bench::WallCaseSpec base;
  double chi_ref = 0.25, length = 2, height = 0;  // height: brenner's H in d (0: the box's W)
  double unbounded = 0;  // the sphere's unbounded drag / Stokes when known (one d/l only); 0: measured
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&] { return option_value(argc, argv, i); };
    if (k == "--out") out = next();
    else if (k == "--diameter") ds = next();
    else if (k == "--gaps" && mode == "brenner") gaps = next();
    else if (k == "--box" && mode == "brenner") boxes = next();
    else if (k == "--height" && mode == "brenner") height = std::stod(next());
    else if (k == "--wall" && mode == "brenner") {
      const std::string w = next();
      if (w != "bb" && w != "psm") throw ConfigError("--wall " + w + ": must be bb (half-way bounce-back) or psm (solid cells)");
      base.psm_wall = w == "psm";
    }
    else if (k == "--lubrication" && mode == "brenner") {
      const std::string w = next();
      if (w != "bench" && w != "engine")
        throw ConfigError("--lubrication " + w + ": must be bench (the bench adds the gap correction to the normalised "
                          "drag) or engine (the coupled step's psm.wall_lubrication kernel adds it to the force)");
      base.engine_lubrication = w == "engine";
    }
    else if (k == "--k" && mode == "tube") ks = next();
    else if (k == "--length" && mode == "tube") length = std::stod(next());
    else if (k == "--tau") base.tau = std::stod(next());
    else if (k == "--magic") magic = next();
    else if (k == "--weights") weight = next();
    else if (k == "--re") base.re = std::stod(next());
    else if (k == "--chi-ref") chi_ref = std::stod(next());
    else if (k == "--unbounded") unbounded = std::stod(next());
    else if (k == "--tol") base.tolerance = std::stod(next());
    else if (k == "--max-steps") base.max_steps = std::stol(next());
    else if (k == "--precision") prec = next();
    else if (k == "--backend") backend = next();
    else throw ConfigError(mode + ": unknown option " + k);
  }
  if (weight != "ntw" && weight != "nt") throw ConfigError("--weights " + weight + ": must be ntw or nt");
  if (unbounded < 0 || (unbounded > 0 && split(ds).size() != 1))
    throw ConfigError("--unbounded " + jnum(unbounded) + ": must be > 0 and given with one --diameter");
  if (!(chi_ref > 0 && chi_ref <= 0.5)) throw ConfigError("--chi-ref " + jnum(chi_ref) + ": must be in (0, 0.5]");
  if (!(base.tau > 0.5)) throw ConfigError("--tau " + jnum(base.tau) + ": must be > 0.5");
  base.weight = weight == "ntw" ? imb::PsmWeight::NobleTorczynskiWall : imb::PsmWeight::NobleTorczynski;
  base.precision = lbm::precision_from_string(prec);
  // Every value checked before any run (a bad one names its option).
  for (const auto& dstr : split(ds)) {
    const double d = std::stod(dstr);
    if (!(d >= 2)) throw ConfigError("--diameter " + dstr + ": must be >= 2 cells");
    if (mode == "brenner")
      for (const auto& bx : split(boxes)) {
        const long W = std::lround(std::stod(bx) * d);
        const long H = height > 0 ? std::lround(height * d) : W;
        if (double(W) < d + 4) throw ConfigError("--box " + bx + ": the box (" + std::to_string(W) + " cells) must be at least d + 4");
        for (const auto& gs : split(gaps)) {
          const double gap = gs.back() == 'd' ? std::stod(gs.substr(0, gs.size() - 1)) * d : std::stod(gs);
          if (!(gap >= 0.5) || 1.0 + d + gap > double(H - 1) - 1.0)
            throw ConfigError("--gaps " + gs + ": the gap must be >= 0.5 cells and leave the sphere a cell below the top "
                              "wall of the box of height " + std::to_string(H) + " cells (--box " + bx + ", --height)");
        }
      }
    else
      for (const auto& kstr : split(ks)) {
        const double k = std::stod(kstr);
        if (!(k > 0 && k <= 0.5)) throw ConfigError("--k " + kstr + ": k = d/D must be in (0, 0.5]");
      }
  }
  if (mode == "tube" && !(length >= 0.5)) throw ConfigError("--length " + jnum(length) + ": must be >= 0.5 (tube lengths D)");
  const Backend b = resolve_backend(backend);
  const std::string dev = bench::device_name(b);
  auto emit = [&](const std::string& line) {
    if (out.empty()) return;
    std::ofstream(out, std::ios::app) << line << "\n";
  };
  for (const auto& dstr : split(ds)) {
    bench::WallCaseSpec s = base;
    s.diameter = std::stod(dstr);
    s.magic = magic == "auto" ? imb::psm_magic_auto(s.diameter, s.tau) : std::stod(magic);
    const double t0 = wall();
    const double unb = unbounded > 0 ? unbounded : bench::unbounded_factor(s, chi_ref, b);
    std::printf("# d/l %s, tau %g, Lambda %.3g, %s, %s: unbounded drag / Stokes = %.5f (array K / Sangani & Acrivos "
                "at chi %g, %.1f s)\n",
                dstr.c_str(), s.tau, s.magic, weight.c_str(), prec.c_str(), unb, chi_ref, wall() - t0);
    std::fflush(stdout);
    std::ostringstream common;
    common << "\"device\": \"" << dev << "\", \"d\": " << jnum(s.diameter) << ", \"tau\": " << jnum(s.tau)
           << ", \"magic\": " << jnum(s.magic) << ", \"weight\": \"" << weight << "\", \"precision\": \"" << prec
           << "\", \"re\": " << jnum(s.re) << ", \"unbounded\": " << jnum(unb) << ", \"chi_ref\": " << jnum(chi_ref);
    if (mode == "brenner") {
      std::printf("| d/l | box W x H | wall | gap | h/a | F/F_St | F/F_inf | Brenner | err %% | + gap corr.%s | err %% | steps | s | "
                  "MLUPS |\n", base.engine_lubrication ? " (engine)" : "");
      std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
      for (const auto& bx : split(boxes)) {
        const long W = std::lround(std::stod(bx) * s.diameter);
        const long H = height > 0 ? std::lround(height * s.diameter) : W;
        for (const auto& gs : split(gaps)) {
          const double gap = gs.back() == 'd' ? std::stod(gs.substr(0, gs.size() - 1)) * s.diameter : std::stod(gs);
          const auto r = bench::run_brenner(s, W, H, gap, b);
          const double lam = r.F / r.F_stokes / unb, err = 100 * (lam / r.lambda - 1);
          // With the gap correction: the bench's (imb::wall_lubrication_lambda, units of the Stokes
          // drag, added to the normalised drag), or the engine's (--lubrication engine: the coupled
          // step's kernel added it to the force, normalised with it).
          const double lamc = s.engine_lubrication ? r.F_engine / r.F_stokes / unb : lam + r.lubrication,
                       errc = 100 * (lamc / r.lambda - 1);
          if (s.engine_lubrication && !r.engine.applied && gs == split(gaps).front())
            std::fprintf(stderr, "# psm.wall_lubrication %s\n", r.engine.note.c_str());
          std::printf("| %s | %ld x %ld | %s | %g | %.4f | %.5f | %.5f | %.5f | %+.2f | %.5f | %+.2f | %ld%s | %.1f | %.1f |\n",
                      dstr.c_str(), W, H, s.psm_wall ? "psm" : "bb", gap, r.h_over_a, r.F / r.F_stokes, lam, r.lambda,
                      err, lamc, errc, r.run.steps, r.run.converged ? "" : "*", r.run.seconds, r.run.mlups);
          std::fflush(stdout);
          std::ostringstream o;
          o << "{\"bench\": \"brenner\", " << common.str() << ", \"box\": " << W << ", \"height\": " << H << ", \"wall\": \"" << (s.psm_wall ? "psm" : "bb") << "\", \"gap\": " << jnum(gap)
            << ", \"h_over_a\": " << jnum(r.h_over_a) << ", \"F_over_stokes\": " << jnum(r.F / r.F_stokes)
            << ", \"lambda\": " << jnum(lam) << ", \"brenner\": " << jnum(r.lambda) << ", \"error\": " << jnum(err / 100)
            << ", \"lubrication\": " << jnum(r.lubrication) << ", \"error_corrected\": " << jnum(errc / 100);
          if (s.engine_lubrication)  // (bench-side lines stay as they were)
            o << ", \"correction\": \"engine\", \"engine_applied\": " << (r.engine.applied ? "true" : "false")
              << ", \"F_engine_over_stokes\": " << jnum(r.F_engine / r.F_stokes);
          o
            << ", \"steps\": " << r.run.steps << ", \"converged\": " << (r.run.converged ? "true" : "false")
            << ", \"remaining\": " << jnum(r.run.remaining) << ", \"seconds\": " << jnum(r.run.seconds)
            << ", \"cells\": " << r.run.cells << ", \"mlups\": " << jnum(r.run.mlups) << "}";
          emit(o.str());
        }
      }
    } else {
      std::printf("| d/l | k | D | W | Lz | K/K_St | K/K_inf | Haberman-Sayre | err %% | steps A+B | s | MLUPS |\n");
      std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
      for (const auto& kstr : split(ks)) {
        const auto r = bench::run_tube(s, std::stod(kstr), length, b);
        const double K = r.K / unb, err = 100 * (K / r.K_ref - 1);
        const long steps = r.a.steps + r.b.steps;
        const double secs = r.a.seconds + r.b.seconds;
        const bool conv = r.a.converged && r.b.converged;
        std::printf("| %s | %s | %.2f | %ld | %ld | %.5f | %.5f | %.5f | %+.2f | %ld%s | %.1f | %.1f |\n", dstr.c_str(),
                    kstr.c_str(), r.D, r.W, r.Lz, r.K, K, r.K_ref, err, steps, conv ? "" : "*", secs,
                    double(r.a.cells) * double(steps) / secs / 1e6);
        std::fflush(stdout);
        std::ostringstream o;
        o << "{\"bench\": \"tube\", " << common.str() << ", \"k\": " << jnum(r.k) << ", \"D\": " << jnum(r.D)
          << ", \"W\": " << r.W << ", \"Lz\": " << r.Lz << ", \"K_over_stokes\": " << jnum(r.K) << ", \"K\": " << jnum(K)
          << ", \"haberman_sayre\": " << jnum(r.K_ref) << ", \"error\": " << jnum(err / 100)
          << ", \"g_zero_flux\": " << jnum(r.g) << ", \"steps\": " << steps << ", \"converged\": " << (conv ? "true" : "false")
          << ", \"remaining\": " << jnum(std::max(r.a.remaining, r.b.remaining)) << ", \"seconds\": " << jnum(secs)
          << ", \"cells\": " << r.a.cells << ", \"mlups\": " << jnum(double(r.a.cells) * double(steps) / secs / 1e6) << "}";
        emit(o.str());
      }
    }
  }
  return 0;
}

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "sweep";
    if (mode == "sweep") return sweep(argc, argv);
    if (mode == "suspension") return suspension(argc, argv);
    if (mode == "drift") return drift(argc, argv);
    if (mode == "wall") return plane_wall(argc, argv);
    if (mode == "random") return random_arrays(argc, argv);
    if (mode == "brenner" || mode == "tube") return wall_cases(mode, argc, argv);
    if (mode == "startup") return bench::startup_main(argc, argv);
    std::fprintf(stderr, "usage: lbdem_bench_psm sweep|suspension|wall|random|brenner|tube|startup|drift [options]\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
