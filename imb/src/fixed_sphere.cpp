#include "imb/fixed_sphere.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "core/error.hpp"
#include "core/run_checks.hpp"
#include "core/signals.hpp"
#include "halo/simulation.hpp"
#include "imb/psm_coupling.hpp"
#include "lbm/fluid_checks.hpp"

namespace lbdem::imb {

double sangani_acrivos_K(double chi) {
  static const double q[31] = {1.000000,  1.418649,  2.012564,   2.331523,  2.564809,  2.584787,  2.873609, 3.340163,
                               3.536763,  3.504092,  3.253622,   2.689757,  2.037769,  1.809341,  1.877347, 1.534685,
                               0.9034708, 0.2857896, -0.5512626, -1.278724, 1.013350,  5.492491,  4.615388, -0.5736023,
                               -2.865924, -4.709215, -6.870076,  0.1455304, 12.51891,  9.742811,  -5.566269};
  double K = 0, p = 1;
  for (double c : q) {
    K += c * p;
    p *= chi;
  }
  return K;
}

double zick_homsy_chi(double phi) { return std::cbrt(6.0 * phi / M_PI); }

double zick_homsy_K(double chi) {
  for (const auto& p : kZickHomsy)
    if (std::abs(chi - zick_homsy_chi(p.phi)) <= kZickHomsyChiTolerance) return p.K;
  return std::numeric_limits<double>::quiet_NaN();
}

double sphere_array_K(double chi, const char** name) {
  const bool series = chi > 0 && chi <= 0.75;
  if (name) *name = series ? "Sangani & Acrivos (1982) Eq. 60" : "Zick & Homsy (1982) Table 2";
  return series ? sangani_acrivos_K(chi) : zick_homsy_K(chi);
}

double sangani_acrivos_cylinders(double c) {
  return 1.0 / (-0.5 * std::log(c) - 0.738 + c - 0.887 * c * c + 2.038 * c * c * c);
}

FixedSphereResult run_fixed_sphere(const FixedSphereSpec& c, Backend b) {
  const bool d3 = c.dim == 3;
  if (c.dim != 2 && c.dim != 3) throw ConfigError(c.keys.dim + " = " + std::to_string(c.dim) + ": must be 2 or 3");
  auto num = [](double v) {
    std::ostringstream o;
    o.precision(7);
    o << v;
    return o.str();
  };
  // The reference: Sangani & Acrivos's series to chi 0.75; above it, in 3D,
  // only the dense points Zick & Homsy tabulate (the table is not interpolated).
  const bool dense = c.chi > 0.75;
  if (!(c.chi > 0) || (dense && (!d3 || std::isnan(zick_homsy_K(c.chi))))) {
    std::string points;
    for (const auto& p : kZickHomsy)
      if (zick_homsy_chi(p.phi) > 0.75)
        points += (points.empty() ? "" : ", ") + num(std::round(zick_homsy_chi(p.phi) * 1e4) / 1e4) + " (phi " +
                  num(p.phi) + ")";
    throw ConfigError(c.keys.chi + " = " + num(c.chi) +
                      ": must be in (0, 0.75] (range of the reference, Sangani & Acrivos's series)" +
                      (d3 ? " or, within " + num(kZickHomsyChiTolerance) +
                                ", a dense point tabulated by Zick & Homsy (1982): " + points
                          : " (2D: no dense reference)"));
  }
  const long L = std::lround(c.diameter / c.chi);
  if (L < 4) throw ConfigError("fixed_sphere: period L = d/chi = " + std::to_string(L) + " cells: must be >= 4");
  if (dense && std::isnan(zick_homsy_K(c.diameter / double(L))))
    throw ConfigError(c.keys.diameter + " = " + num(c.diameter) + " with " + c.keys.chi + " = " + num(c.chi) +
                      ": the period L = round(d / chi) = " + std::to_string(L) + " cells makes d / L = " +
                      num(c.diameter / double(L)) + ", off the tabulated point by more than " +
                      num(kZickHomsyChiTolerance) + ": use d = " + num(c.chi) + " * L, e.g. " +
                      num(c.chi * double(L)));
  const double a = 0.5 * c.diameter;
  // The cell map visits floor(2a) + 2 cells per axis around a particle and
  // refuses more than a periodic axis holds (imb/cell_slots.hpp: a particle
  // would meet its own image), which a sphere with less than about a cell of
  // gap to its neighbour in the array needs. The array is then simulated on a
  // period of 2L per axis holding a sphere at the same place in each L-cell:
  // the flow stays L-periodic, and every sum below is per sphere.
  if (c.periods < 0 || c.periods > 4)
    throw ConfigError(c.keys.periods + " = " + std::to_string(c.periods) + ": must be 0 (as needed) or 1-4");
  const long rep = c.periods > 0 ? c.periods : static_cast<long>(std::floor(2.0 * a)) + 2 > L ? 2 : 1;
  const long M = rep * L;  // cells per axis of the simulated domain
  const int spheres = static_cast<int>(d3 ? rep * rep * rep : rep * rep);
  const double nu = (c.tau - 0.5) / 3.0, mu = nu;  // rho = 1
  const double V = d3 ? double(L) * L * L : double(L) * L;
  const double phi = d3 ? M_PI * c.diameter * c.diameter * c.diameter / 6.0 / V : M_PI * a * a / V;
  const double chi_true = c.diameter / double(L);
  const char* reference = "Sangani & Acrivos (1982), square array of cylinders";
  double K_ref = 0;
  if (!d3) K_ref = sangani_acrivos_cylinders(phi);
  else if (dense) K_ref = sphere_array_K(chi_true, &reference);  // d / L is within the tolerance of the point
  else {
    K_ref = sangani_acrivos_K(chi_true);
    reference = "Sangani & Acrivos (1982) Eq. 60";
  }
  // Body force g per unit volume for the target Re_p (Stokes estimate):
  // the array theory's force balance is n F = -grad p = g, F = 6 pi mu a K U.
  const double U_target = c.re_p * nu / c.diameter;
  const double F_target = d3 ? 6 * M_PI * mu * a * K_ref * U_target : 4 * M_PI * mu * K_ref * U_target;
  const double g = F_target / V;

  lbm::LbmSetup s;
  s.lattice = d3 ? lbm::LatticeKind::D3Q19 : lbm::LatticeKind::D2Q9;
  s.precision = c.precision;
  s.collision = c.collision;
  s.streaming = c.streaming;
  s.tau = c.tau;
  s.magic = c.magic;
  s.domain.global = s.domain.local = {M, M, d3 ? M : 1};
  s.body_force = {g, 0, 0};
  // On several ranks each takes its piece of the period (ghost cells flagged)
  // and exchanges halos; sums over cells (drag, mean velocity) are over ranks.
  const bool cut = c.comm && c.comm->distributed();
  halo::Decomposition dec;
  if (cut) {
    dec = halo::decompose(s.domain, c.comm->size(), c.parallel.decomposition, "parallel.decomposition");
    s.domain = dec.piece(s.domain, c.comm->rank());
  }
  auto solver = lbm::make_lbm_solver(s, b);
  const double N = d3 ? double(M) * M * M : double(M) * M;  // cells of the whole domain
  const auto Ns = static_cast<std::size_t>(s.domain.storage_cells());
  const GridView gv = s.domain.view();
  const CellBox own = s.domain.owned();
  std::vector<std::uint8_t> flags(Ns, 0);
  std::vector<char> owned(Ns, 0);  // owned cells: what this rank adds to the sums
  for (Index t = 0; t < own.size(); ++t) {
    int x, y, z;
    own.coords(t, x, y, z);
    owned[static_cast<std::size_t>(gv.index(x, y, z))] = 1;
  }
  for (std::size_t i = 0; i < Ns; ++i)
    if (!owned[i]) flags[i] = lbm::kGhostFlag;
  solver->initialize(flags, std::vector<double>(Ns, 1.0), std::vector<double>(3 * Ns, 0.0));
  std::unique_ptr<halo::Transport> transport;
  std::unique_ptr<lbm::FluidHalo> halo;
  if (cut) {
    transport = halo::make_transport(c.parallel.transport, *c.comm, b);
    halo = std::make_unique<lbm::FluidHalo>(*solver, dec, c.comm->rank(), *transport);
    halo->fill();
  }
  auto global_sum = [&](std::vector<double> v) {
    if (cut) c.comm->sum(v);
    return v;
  };

  // Particle arrays x, y, z, r, v, w of `spheres` entries each (at rest).
  const double ctr = 0.5 * L + c.offset;
  const std::size_t n = static_cast<std::size_t>(spheres);
  std::vector<double> host(10 * n, 0.0);
  for (long k = 0, i = 0; k < (d3 ? rep : 1); ++k)
    for (long j = 0; j < rep; ++j)
      for (long q = 0; q < rep; ++q, ++i) {
        host[i] = ctr + double(q * L);
        host[n + i] = ctr + double(j * L);
        host[2 * n + i] = d3 ? ctr + double(k * L) : 0.5;
        host[3 * n + i] = a;
      }
  Buffer<double> pd(b, 10 * spheres);
  pd.copy_from_host(host);
  Buffer<double> f6(b, 6 * spheres);
  imb::PsmParticles p;
  double* d = pd.data();
  p.x = d; p.y = d + n; p.z = d3 ? d + 2 * n : nullptr; p.r = d + 3 * n;
  p.vx = d + 4 * n; p.vy = d + 5 * n; p.vz = d + 6 * n; p.wx = d + 7 * n; p.wy = d + 8 * n; p.wz = d + 9 * n;
  p.n = spheres;
  imb::PsmCoupling coupling(*solver, c.slots);
  imb::PsmOptions opt;
  opt.variant = c.variant;
  opt.weight = c.weight;
  opt.even_relaxation = c.even_relaxation;
  opt.map.method = c.method;
  opt.map.max_radius = a;
  opt.map.table = c.table;
  // A fixed sphere is mapped once: the mapped pipeline reads its slots every
  // step instead of recomputing the fractions (imb/psm_coupling.hpp).
  opt.pipeline = c.pipeline == imb::PsmPipeline::Fused ? imb::PsmPipeline::Fused : imb::PsmPipeline::Mapped;
  coupling.map(p, opt, true);
  if (c.start == FixedSphereSpec::Start::Estimate) {
    // u = U0 (1 - eps) along x: zero inside the sphere, the Stokes estimate's
    // superficial velocity sum (1 - eps) u / V = U_target.
    const auto eps0 = coupling.slots().total_eps_host();
    double s2 = 0;
    for (std::size_t i = 0; i < Ns; ++i)
      if (owned[i]) s2 += (1.0 - std::min(1.0, eps0[i])) * (1.0 - std::min(1.0, eps0[i]));
    s2 = global_sum({s2})[0];
    const double U0 = U_target * V * spheres / s2;
    std::vector<double> u0(3 * Ns, 0.0);
    for (std::size_t i = 0; i < Ns; ++i) u0[3 * i] = U0 * (1.0 - std::min(1.0, eps0[i]));
    solver->initialize(flags, std::vector<double>(Ns, 1.0), u0);
    if (halo) halo->fill();
  }
  auto psm_step = [&](const imb::ForceOut& out) {
    if (halo) coupling.step(p, opt, out, *halo);
    else coupling.step(p, opt, out);
  };
  // Steady state: the drag approaches its limit like A e^{-t/T}; with the
  // change D over an interval and the ratio r of successive changes, the
  // remaining change is D r / (1 - r). Stop when that is below tolerance.
  const long check = c.check_every > 0 ? c.check_every : std::max<long>(50, std::lround(L * L / (40 * nu)));
  const auto t0 = std::chrono::steady_clock::now();
  double F = 0, prev = 0, prev_delta = 0, remaining_rel = 1;
  bool converged = false;
  // The loop (halo/simulation.hpp) runs whole intervals of `check` steps
  // (max_steps rounded up), polls stop signals after the step in progress
  // (several ranks agree every ~0.25 s of steps) and ends early at a steady
  // drag. The solid kernel writes its per-cell forces every step; only the
  // last step of an interval gathers them (a null force skips the gather).
  const halo::Comm& comm = c.comm ? *c.comm : halo::Comm::world();
  sim::Simulation loop(comm, "fixed_sphere", 0, (c.max_steps + check - 1) / check * check,
                       sim::Stepping{.wait = [&] { solver->synchronize(); }});
  long done = 0;
  auto advance = [&](long steps) {
    for (long k = 0; k < steps; ++k) {
      ++done;
      psm_step(done % check == 0 ? imb::ForceOut::six(f6.data()) : imb::ForceOut{});
    }
  };
  loop.add("drag", sim::Trigger::steps(check), [&](const sim::Event& ev) {
    const long step = ev.step;
    const auto f = f6.to_vector();
    F = f[0];
    for (std::size_t i = 1; i < n; ++i) F += f[6 * i];
    F = global_sum({F})[0] / spheres;
    if (!std::isfinite(F)) throw DivergenceError("fixed_sphere: drag is not finite at step " + std::to_string(step));
    const double delta = std::abs(F - prev);
    if (step >= 4 * check && prev_delta > 0) {
      const double r = std::min(delta / prev_delta, 0.999);
      const double remaining = delta * std::max(1.0, r / (1.0 - r));
      remaining_rel = remaining / std::abs(F);
      if (!c.quiet) {
        std::fprintf(stderr, "  step %ld: F = %.9e, ratio %.4f, remaining ~ %.2e\n", step, F, r, remaining_rel);
        {  // densities by cover (this rank's cells): the mass exchange with covered cells, bench/imb/NOTES.md
          std::vector<double> rr, uu;
          solver->macroscopic(rr, uu);
          const auto ee = coupling.slots().total_eps_host();
          double fm = 0, fv = 0, sm = 0, sv = 0, pm = 0, pv = 0, tot = 0, us = 0, jx = 0;
          for (std::size_t i = 0; i < Ns; ++i) {
            if (!owned[i]) continue;
            const double e = std::min(1.0, ee[i]);
            fm += (1 - e) * rr[i];
            fv += 1 - e;
            tot += rr[i];
            us += (1 - e) * uu[3 * i];
            jx += rr[i] * uu[3 * i];
            if (e >= 1) {
              sm += rr[i];
              sv += 1;
            } else if (e > 0) {
              pm += rr[i];
              pv += 1;
            }
          }
          std::fprintf(stderr,
                       "  diag %ld: fluid_rho %.9f covered_rho %.6f partial_rho %.6f mean_rho %.12f usup %.6e j %.6e\n",
                       step, fm / fv, sv > 0 ? sm / sv : 0.0, pv > 0 ? pm / pv : 0.0, tot / N, us / N, jx / N);
        }
      }
      if (remaining < c.tolerance * std::abs(F)) {
        converged = true;
        loop.end_here();
        return;
      }
    }
    prev_delta = step >= 2 * check ? delta : 0;
    prev = F;
  });
  loop.run(advance);
  const long step = loop.step();
  const bool interrupted = loop.interrupted();
  solver->synchronize();
  FixedSphereResult r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.steps = step;
  r.converged = converged;
  r.interrupted = interrupted;
  r.remaining = remaining_rel;
  r.mlups = N * double(step) / r.seconds / 1e6;
  r.cells = std::lround(N);

  std::vector<double> rho, u;
  solver->macroscopic(rho, u);
  const auto eps = coupling.slots().total_eps_host();
  double usum = 0, fluid_weight = 0, flux = 0, fluid_mass = 0, fluid_vol = 0, mass = 0;
  for (std::size_t i = 0; i < Ns; ++i) {
    if (!owned[i]) continue;
    const double e = std::min(1.0, eps[i]);
    usum += (1.0 - e) * u[3 * i];
    flux += rho[i] * u[3 * i];
    const double B = imb::psm_weight(e, imb::psm_weight_t(c.tau, c.weight), c.weight);
    fluid_weight += 1.0 - B;
    fluid_mass += (1.0 - e) * rho[i];
    fluid_vol += 1.0 - e;
    mass += rho[i];
  }
  const auto sums = global_sum({usum, flux, fluid_weight, fluid_mass, fluid_vol, mass});
  usum = sums[0] / spheres;  // per period
  flux = sums[1] / spheres;
  fluid_weight = sums[2] / spheres;
  r.fluid_rho = sums[3] / sums[4];
  r.mean_rho = sums[5] / N;
  r.mean_u = usum / V;
  r.mean_flux = flux / V;
  r.exchange = F;
  r.balance = g * fluid_weight;
  // The fluid receives the body force in proportion (1 - B) in each cell; at
  // steady state that equals the measured exchange. The array theory's force
  // is the one that balances a mean pressure gradient g acting on the whole
  // period: F = g V.
  r.force = g * V;
  r.body_force = g;
  r.K = d3 ? r.force / (6 * M_PI * mu * a * r.mean_u) : r.force / (4 * M_PI * mu * r.mean_u);
  r.K_ref = K_ref;
  r.reference = reference;
  r.rel_error = (r.K - K_ref) / K_ref;
  r.re_p = r.mean_u * c.diameter / nu;
  return r;
}

void check_fixed_sphere(const Config& root, int dim, double diameter, double chi, lbm::Precision precision,
                        lbm::StreamKind streaming, long max_steps, Backend backend, bool force,
                        const std::string& steps_key) {
  lbm::LbmSetup fluid;
  fluid.lattice = dim == 3 ? lbm::LatticeKind::D3Q19 : lbm::LatticeKind::D2Q9;
  fluid.precision = precision;
  fluid.streaming = streaming;
  const long L = std::lround(diameter / chi);
  if (L < 4)
    throw ConfigError(root.source() + ": keys 'geometry.diameter' = " + checks::num(diameter) + ", 'geometry.chi' = " +
                      checks::num(chi) + ": the array period L = d / chi = " + std::to_string(L) +
                      " cells is too short to hold a resolved sphere and the flow around it; use L >= 4 (a larger "
                      "diameter or a smaller chi)");
  const double cells = dim == 3 ? double(L) * L * L : double(L) * L;
  const double bytes = lbm::lbm_grid_bytes(fluid, cells);
  check_memory(root, backend, bytes, cells * (1 + 5 * sizeof(double)), "geometry.diameter, geometry.chi",
               "the grid of " + checks::num(cells) + " cells (L = d / chi = " + std::to_string(L) + ")",
               "use a smaller diameter or a larger chi");
  check_plan(root, force, double(max_steps), cells, 0, steps_key);
}

}  // namespace lbdem::imb
