// lbdem_bench_imb --out FILE.json [--quick]
//
// Speed against error of the three solid-fraction methods (imb/solid_fraction.hpp):
//  * error vs the exact method over the interface band (max, RMS per cell) and
//    the relative error of Σε against the particle volume, 2D and 3D, R = 3…25;
//  * cost per interface cell (ns) of evaluate_fractions on the host (all OpenMP
//    threads) and on the GPU when one is usable;
//  * CellSlots::map time for 500 and 20,000 particles of R = 5 in a 256³
//    periodic box (random centres, overlaps allowed: 20,000 balls of R = 5 are a
//    nominal solid fraction of 0.62), K = 12.
// Timing: one warm-up, then the median of repeats; GPU times include a
// device synchronise. Prints a markdown table and writes JSON.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "core/buffer.hpp"
#include "core/exec.hpp"
#include "imb/cell_slots.hpp"

using namespace lbdem;
using namespace lbdem::imb;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

template <class F>
double median_time(int reps, const Exec& ex, F f) {
  f();
  ex.synchronize();
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    const double t0 = now();
    f();
    ex.synchronize();
    t.push_back(now() - t0);
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

struct ErrRow {
  int dim;
  double R;
  std::string method;
  double max_err, rms_err, vol_err;  // vol_err: max |Σε/V − 1| over the centres
  long cells;
};
struct CostRow {
  int dim;
  std::string method, backend;
  double ns_per_cell;
  long cells;
};
struct MapRow {
  std::string method, backend;
  long particles;
  double ms;
  long overflow_events;
};

double eval_one(FractionMethod m, int dim, const FractionTable& t, double rx, double ry, double rz, double R) {
  const auto acc = t.host_access();
  switch (m) {
    case FractionMethod::Exact: return dim == 3 ? exact_fraction_3d(rx, ry, rz, R) : exact_fraction_2d(rx, ry, R);
    case FractionMethod::Table:
      return dim == 3 ? table_fraction_3d(t.geometry, acc, rx, ry, rz, R) : table_fraction_2d(t.geometry, acc, rx, ry, R);
    case FractionMethod::Linear: {
      const double re = dim == 3 ? linear_effective_radius_3d(R) : linear_effective_radius_2d(R);
      return linear_fraction(std::sqrt(rx * rx + ry * ry + (dim == 3 ? rz * rz : 0.0)), re);
    }
  }
  return 0.0;
}

// Centre-relative positions of the interface cells of a particle of radius R at several sub-cell centres.
std::vector<double> band_cells(int dim, double R, int centres, unsigned seed, std::vector<double>& radius) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::vector<double> rel;
  for (int c = 0; c < centres; ++c) {
    const double cx = U(g), cy = U(g), cz = dim == 3 ? U(g) : 0.5;
    const int B = static_cast<int>(R) + 2;
    for (int k = dim == 3 ? -B : 0; k <= (dim == 3 ? B : 0); ++k)
      for (int j = -B; j <= B; ++j)
        for (int i = -B; i <= B; ++i) {
          const double rx = i + 0.5 - cx, ry = j + 0.5 - cy, rz = dim == 3 ? k + 0.5 - cz : 0.0;
          const double n2 = cell_near2(rx, ry, rz), f2 = dim == 3 ? cell_far2(rx, ry, rz)
                                                                : (std::fabs(rx) + .5) * (std::fabs(rx) + .5) +
                                                                      (std::fabs(ry) + .5) * (std::fabs(ry) + .5);
          if (n2 < R * R && f2 > R * R) {
            rel.push_back(rx);
            rel.push_back(ry);
            if (dim == 3) rel.push_back(rz);
            radius.push_back(R);
          }
        }
  }
  return rel;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_path;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) out_path = argv[++i];
    else if (!std::strcmp(argv[i], "--quick")) quick = true;
    else {
      std::fprintf(stderr, "usage: %s --out FILE.json [--quick]\n", argv[0]);
      return 2;
    }
  }
  const bool gpu = cuda_compiled() && cuda_unavailable_reason().empty();
  const std::string device = bench::device_name(gpu ? Backend::Cuda : Backend::Host);
  const std::string commit = bench::git_commit();
  std::printf("lbdem_bench_imb: GPU %s; commit %s\n", gpu ? "usable" : ("not used: " + cuda_unavailable_reason()).c_str(),
              commit.c_str());
  const FractionTable t3 = build_fraction_table(3), t2 = build_fraction_table(2);
  const FractionMethod methods[3] = {FractionMethod::Exact, FractionMethod::Table, FractionMethod::Linear};

  // ---- error ---------------------------------------------------------------
  std::vector<ErrRow> errs;
  const std::vector<double> radii = quick ? std::vector<double>{3, 5, 10} : std::vector<double>{3, 5, 8, 10, 16, 25};
  for (int dim : {2, 3}) {
    const FractionTable& tab = dim == 3 ? t3 : t2;
    for (double R : radii) {
      const int centres = 8;
      std::mt19937_64 g(100 + static_cast<unsigned>(R * 10));
      std::uniform_real_distribution<double> U(0, 1);
      double mx[3] = {0, 0, 0}, ss[3] = {0, 0, 0}, ve[3] = {0, 0, 0};
      long nb = 0;
      for (int c = 0; c < centres; ++c) {
        const double cx = U(g), cy = U(g), cz = dim == 3 ? U(g) : 0.5;
        const int B = static_cast<int>(R) + 2;
        double sm[3] = {0, 0, 0};
        for (int k = dim == 3 ? -B : 0; k <= (dim == 3 ? B : 0); ++k)
          for (int j = -B; j <= B; ++j)
            for (int i = -B; i <= B; ++i) {
              const double rx = i + 0.5 - cx, ry = j + 0.5 - cy, rz = dim == 3 ? k + 0.5 - cz : 0.0;
              const double e = eval_one(FractionMethod::Exact, dim, tab, rx, ry, rz, R);
              const bool band = e > 0.0 && e < 1.0;
              nb += band;
              for (int m = 0; m < 3; ++m) {
                const double v = m == 0 ? e : eval_one(methods[m], dim, tab, rx, ry, rz, R);
                sm[m] += v;
                if (band || (v > 0 && v < 1)) {
                  mx[m] = std::max(mx[m], std::fabs(v - e));
                  ss[m] += (v - e) * (v - e);
                }
              }
            }
        const double V = dim == 3 ? 4.0 / 3.0 * M_PI * R * R * R : M_PI * R * R;
        for (int m = 0; m < 3; ++m) ve[m] = std::max(ve[m], std::fabs(sm[m] / V - 1.0));
      }
      for (int m = 0; m < 3; ++m)
        errs.push_back({dim, R, to_string(methods[m]), mx[m], std::sqrt(ss[m] / std::max<long>(nb, 1)), ve[m], nb});
    }
  }

  // ---- cost per interface cell ----------------------------------------------
  std::vector<CostRow> costs;
  for (int dim : {2, 3}) {
    const FractionTable& tab = dim == 3 ? t3 : t2;
    std::vector<double> radius;
    std::vector<double> rel = band_cells(dim, 10.0, quick ? 4 : 16, 7, radius);
    const Index n = static_cast<Index>(radius.size());
    std::vector<Backend> bs{Backend::Host};
    if (gpu) bs.push_back(Backend::Cuda);
    for (Backend b : bs) {
      // Replicate the band to fill the machine: ≥ 4M cells on the GPU, ≥ 64k (quick: 8k) on the host.
      const Index target = b == Backend::Cuda ? 4'000'000 : (quick ? 8'000 : 64'000);
      const int rep = std::max<int>(1, static_cast<int>((target + n - 1) / n));
      std::vector<double> rel_r, rad_r;
      for (int r = 0; r < rep; ++r) {
        rel_r.insert(rel_r.end(), rel.begin(), rel.end());
        rad_r.insert(rad_r.end(), radius.begin(), radius.end());
      }
      const Index nn = static_cast<Index>(rad_r.size());
      Buffer<double> drel(b, nn * dim), drad(b, nn), dout(b, nn);
      drel.copy_from_host(rel_r);
      drad.copy_from_host(rad_r);
      Exec ex(b);
      for (int mi = 0; mi < 4; ++mi) {
        const FractionMethod m = mi < 3 ? methods[mi] : FractionMethod::Table;
        const bool in_constant = mi < 3;
        if (!in_constant && b != Backend::Cuda) continue;
        const int reps = b == Backend::Cuda ? 11 : (m == FractionMethod::Exact ? 3 : 11);
        const double t = median_time(reps, ex, [&] {
          evaluate_fractions(ex, m, dim, &tab, drel.data(), drad.data(), dout.data(), nn, in_constant);
        });
        costs.push_back({dim, in_constant ? to_string(m) : std::string("table(global)"), to_string(b), t / nn * 1e9,
                         static_cast<long>(nn)});
      }
    }
  }

  // ---- mapping ----------------------------------------------------------------
  std::vector<MapRow> maps;
  const Index L = quick ? 96 : 256;
  const std::vector<long> counts = quick ? std::vector<long>{50, 500} : std::vector<long>{500, 20000};
  for (long np : counts) {
    std::mt19937_64 g(42);
    std::uniform_real_distribution<double> U(0, static_cast<double>(L));
    std::vector<double> xs(np), ys(np), zs(np), rs(np, 5.0);
    for (long i = 0; i < np; ++i) {
      xs[i] = U(g);
      ys[i] = U(g);
      zs[i] = U(g);
    }
    std::vector<Backend> bs{Backend::Host};
    if (gpu) bs.push_back(Backend::Cuda);
    for (Backend b : bs) {
      Buffer<double> bx(b, np), by(b, np), bz(b, np), br(b, np);
      bx.copy_from_host(xs);
      by.copy_from_host(ys);
      bz.copy_from_host(zs);
      br.copy_from_host(rs);
      SphereView v{bx.data(), by.data(), bz.data(), br.data(), np};
      CellSlots slots(b, Grid::whole({L, L, L}), 12);
      Exec ex(b);
      // Variants: 0-2 the three methods (defaults), 3 table in global memory, 4 exact without the deferred pass.
      const char* names[5] = {"exact", "table", "linear", "table(global)", "exact(direct)"};
      for (int mi = 0; mi < 5; ++mi) {
        const FractionMethod m = mi == 3 ? FractionMethod::Table : (mi == 4 ? FractionMethod::Exact : methods[mi]);
        if (mi == 3 && b != Backend::Cuda) continue;
        if (mi == 4 && (b != Backend::Cuda || np > 1000)) continue;
        MapOptions o;
        o.method = m;
        o.table = &t3;
        o.max_radius = 5.0;
        o.table_in_constant = mi != 3;
        o.defer_exact = mi != 4;
        const int reps = b == Backend::Cuda ? 7 : ((m == FractionMethod::Exact && np > 1000) ? 1 : 3);
        const double t = median_time(reps, ex, [&] { slots.map(ex, v, o); });
        const auto rep = slots.overflow();
        maps.push_back({names[mi], to_string(b), np, t * 1e3, static_cast<long>(rep.events)});
      }
    }
  }

  // ---- report -------------------------------------------------------------------
  std::printf("\n### Error against the exact method (interface band; vol = max over 8 centres of |Σε/V − 1|)\n\n");
  std::printf("| dim | R | method | max abs | RMS | vol rel | band cells |\n|---|---|---|---|---|---|---|\n");
  for (const auto& e : errs)
    std::printf("| %dD | %g | %s | %.2e | %.2e | %.2e | %ld |\n", e.dim, e.R, e.method.c_str(), e.max_err, e.rms_err,
                e.vol_err, e.cells);
  std::printf("\n### Cost per interface cell (R = 10)\n\n| dim | method | backend | ns/cell | cells |\n|---|---|---|---|---|\n");
  for (const auto& c : costs)
    std::printf("| %dD | %s | %s | %.3g | %ld |\n", c.dim, c.method.c_str(), c.backend.c_str(), c.ns_per_cell, c.cells);
  std::printf("\n### CellSlots::map, R = 5, %ld³ periodic box, K = 12\n\n| particles | method | backend | ms | overflow pairs |\n|---|---|---|---|---|\n",
              static_cast<long>(L));
  for (const auto& m : maps)
    std::printf("| %ld | %s | %s | %.3f | %ld |\n", m.particles, m.method.c_str(), m.backend.c_str(), m.ms,
                m.overflow_events);

  if (!out_path.empty()) {
    std::ofstream o(out_path);
    if (!o) {
      std::fprintf(stderr, "cannot write %s\n", out_path.c_str());
      return 1;
    }
    o.precision(6);
    o << "{\n" << bench::json_header("lbdem_bench_imb", device, {}) << ",\n  \"gpu\": " << (gpu ? "true" : "false") << ",\n  \"quick\": "
      << (quick ? "true" : "false") << ",\n  \"box\": " << L << ",\n  \"table\": {\"nodes_3d\": ["
      << t3.geometry.nt << ", " << t3.geometry.nu << ", " << t3.geometry.nv << "], \"nodes_2d\": [" << t2.geometry.nt
      << ", " << t2.geometry.nu << "], \"bytes_3d\": " << t3.values.size() * 4 << ", \"fit_radii\": [" << t3.r_fit_a
      << ", " << t3.r_fit_b << "]},\n  \"error\": [\n";
    for (std::size_t i = 0; i < errs.size(); ++i) {
      const auto& e = errs[i];
      o << "    {\"dim\": " << e.dim << ", \"R\": " << e.R << ", \"method\": \"" << e.method << "\", \"max_abs\": "
        << e.max_err << ", \"rms\": " << e.rms_err << ", \"vol_rel\": " << e.vol_err << ", \"band_cells\": " << e.cells
        << "}" << (i + 1 < errs.size() ? "," : "") << "\n";
    }
    o << "  ],\n  \"cost\": [\n";
    for (std::size_t i = 0; i < costs.size(); ++i) {
      const auto& c = costs[i];
      o << "    {\"dim\": " << c.dim << ", \"method\": \"" << c.method << "\", \"backend\": \"" << c.backend
        << "\", \"ns_per_cell\": " << c.ns_per_cell << ", \"cells\": " << c.cells << "}"
        << (i + 1 < costs.size() ? "," : "") << "\n";
    }
    o << "  ],\n  \"mapping\": [\n";
    for (std::size_t i = 0; i < maps.size(); ++i) {
      const auto& m = maps[i];
      o << "    {\"particles\": " << m.particles << ", \"R\": 5, \"K\": 12, \"method\": \"" << m.method
        << "\", \"backend\": \"" << m.backend << "\", \"ms\": " << m.ms << ", \"overflow_pairs\": "
        << m.overflow_events << "}" << (i + 1 < maps.size() ? "," : "") << "\n";
    }
    o << "  ]\n}\n";
    std::printf("\nwrote %s\n", out_path.c_str());
  }
  return 0;
}
