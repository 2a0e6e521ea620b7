#pragma once
// The start-up of a freely moving sphere from rest (issue 29), resolved with
// partially saturated cells, against the unsteady Stokes solution of
// startup_reference.hpp.
//
// Scene: a sphere of diameter d (cells) and density ratio r = rho_p / rho in
// a fully periodic cube of L = box * d cells, fluid and sphere at rest; from
// step 0 a constant force F along x acts on the sphere (DemParams::body_force:
// no gravity, so no buoyancy). It runs through the engine's coupled step
// (imb::CoupledSolver: PSM fluid step, velocity-Verlet DEM, remap), with the
// fluid body force f_b = -F / V (V = L^3) that a fully periodic coupled run
// needs (the mean pressure gradient carrying the sphere's load; without it
// the whole box accelerates without bound). F is chosen so that Stokes's
// unbounded terminal velocity u_T = F / (6 pi mu a) gives Re_p = u_T d / nu.
//
// Frame. f_b acts on every cell (fluid, and the sphere's share B per cell,
// PsmOptions::body_force_on_solid), so far from the sphere the fluid
// accelerates uniformly at a_b = f_b / rho. In the frame that accelerates with
// it the fluid has no body force and is at rest at infinity, and the sphere
// feels, besides the flow's force, F + f_b V_p - m_p a_b =
// F (1 + (r - 1) phi), phi = V_p / V (using V_p for the sphere's share of f_b,
// sum B = V_p up to the weighting of the partial cells: a relative error of
// order phi times a few %). Until the box matters the problem in that frame
// is exactly the reference's, with the velocity v - a_b t and the force
// F (1 + (r - 1) phi).
//
// The fluid inside the sphere. PSM keeps fluid in the covered cells and the
// solid term drives it to the sphere's velocity; its momentum change comes
// from the sphere (nothing corrects for it, unlike Uhlmann 2005's internal
// term). A PSM sphere of density ratio r therefore moves like a rigid sphere
// of density ratio r + 1 (the same applied force; its force in the
// accelerated frame is then F (1 + r phi), the same expression with r + 1).
// The case reports the error against both references: the physical one
// (density r) and the PSM-equivalent one (r + 1).
//
// Where the box matters. The images act from the start: the cube's mean flow
// keeps the impulse the sphere gives the fluid, and the images' irrotational
// (dipole) flows return a third of it to the sphere, F t / (3 rho V): 2 pi T
// (a / L)^3 of u_T (startup_periodic's kernel at short times). Their vortical
// flows arrive once sqrt(nu t) ~ L / 2. So the whole curve is compared with
// the periodic-cube model of startup_reference.hpp (startup_periodic, at
// density r and r + 1), and the unbounded reference only over the window
// sqrt(nu t) <= window * L (default 1/4), i.e. t <= (window L)^2 / nu, where
// the difference is mostly that linear share. At late times the box sets
// the terminal velocity: the sphere's steady slip against the mean composite
// velocity J (fluid and solid, the array theory's U; J = the fluid's
// momentum / V at rho = 1, the PSM's interior fluid included) satisfies
// F = 6 pi mu a U K(phi), K from Hasimoto (1959):
// 1/K = 1 - 1.7601 phi^{1/3} + phi - 1.5593 phi^2, and Sangani & Acrivos
// (1982)'s K for simple cubic arrays (imb::sangani_acrivos_K, accurate to
// larger phi). The run lasts `settle` e-folds of the box's slowest viscous
// mode, exp(-nu (2 pi / L)^2 t), past which the box's transient is below
// e^{-settle} of itself.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/exec.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/drag_error.hpp"
#include "imb/fixed_sphere.hpp"
#include "lbm/solver.hpp"
#include "startup_reference.hpp"

namespace lbdem::bench {

struct StartupSpec {
  double diameter = 6;     // d / l
  double ratio = 2;        // rho_p / rho
  double tau = 0.8;
  double magic = -1;       // TRT Lambda; < 0: imb::psm_magic_auto(d, tau) (the default's `magic: auto`)
  imb::PsmWeight weight = imb::PsmWeight::NobleTorczynskiWall;
  lbm::Precision precision = lbm::Precision::FP64;
  double re = 0.2;         // Re_p of Stokes's unbounded terminal velocity
  double box = 6;          // L = round(box * d) cells
  double window = 0.25;    // the curve is compared while sqrt(nu t) <= window * L
  double settle = 8;       // run length: e-folds of the box's slowest viscous mode
  int samples = 40;        // samples per t_nu = a^2 / nu (at least one per step)
};

// Hasimoto (1959, J. Fluid Mech. 5, 317): the drag factor K of a simple cubic
// array of spheres at solid fraction phi, 1/K = 1 - 1.7601 phi^{1/3} + phi - 1.5593 phi^2.
inline double hasimoto_K(double phi) {
  return 1.0 / (1 - 1.7601 * std::cbrt(phi) + phi - 1.5593 * phi * phi);
}

struct StartupSample {
  long step = 0;
  double T = 0;         // t nu / a^2
  double v = 0;         // the sphere's velocity (lab frame, lattice units)
  double u = 0;         // v - a_b t over u_T(F (1 + (r - 1) phi)): the physical reference's scale
  double u_psm = 0;     // the same over u_T(F (1 + r phi)): the PSM-equivalent reference's scale
  double ref = 0;       // unbounded reference u / u_T at density r (startup_reference.hpp Eq. 2)
  double box = 0;       // periodic-cube model at density r (startup_periodic)
  double box_psm = 0;   // periodic-cube model at density r + 1
  bool in_window = false;
};

struct StartupResult {
  std::vector<StartupSample> samples;
  long L = 0, steps = 0, window_steps = 0;
  double a = 0, nu = 0, t_nu = 0, phi = 0, F = 0, u_T = 0, magic = 0;
  // Curve errors in units of u_T: against the unbounded reference over the
  // window (RMS and max of u - ref), against the periodic-cube model over the
  // whole run (u - box, u_psm - box_psm).
  double rms = 0, max = 0, rms_box = 0, max_box = 0, rms_box_psm = 0, max_box_psm = 0;
  double T_window = 0, T_end = 0;
  // Terminal: the slip against the mean composite velocity J (from the
  // fluid's momentum) over F / (6 pi mu a), (v - J) 6 pi mu a / F, against 1 / K.
  double v_end = 0, J = 0, terminal = 0, hasimoto = 0, sangani_acrivos = 0;
  // The lab velocity at the end over F / (6 pi mu a), and the periodic models' (r, r + 1).
  double lab_end = 0, lab_box = 0, lab_box_psm = 0;
  double late_change = 0;  // relative change of v over the last 10 % of the run (steadiness)
  double seconds = 0, mlups = 0;
  long cells = 0;
};

inline StartupResult run_startup(const StartupSpec& s, Backend b) {
  if (!(s.diameter >= 4)) throw ConfigError("startup: diameter " + std::to_string(s.diameter) + ": must be >= 4 cells");
  if (!(s.ratio >= 1)) throw ConfigError("startup: density ratio " + std::to_string(s.ratio) + ": must be >= 1 (a sphere lighter than the fluid is outside what this case was checked for)");
  if (!(s.box >= 3)) throw ConfigError("startup: box " + std::to_string(s.box) + ": must be >= 3 diameters");
  if (!(s.re > 0 && s.re <= 1)) throw ConfigError("startup: Re_p " + std::to_string(s.re) + ": must be in (0, 1] (Stokes regime)");
  StartupResult r;
  const double d = s.diameter, a = 0.5 * d, nu = (s.tau - 0.5) / 3.0, rho = 1.0;
  r.a = a;
  r.nu = nu;
  r.t_nu = a * a / nu;
  r.L = std::lround(s.box * d);
  const double L = double(r.L), V = L * L * L;
  const double Vp = 4.0 / 3.0 * M_PI * a * a * a;
  r.phi = Vp / V;
  r.u_T = s.re * nu / d;
  r.F = 6 * M_PI * rho * nu * a * r.u_T;
  r.magic = s.magic >= 0 ? s.magic : imb::psm_magic_auto(d, s.tau);
  const double k1 = 2 * M_PI / L;
  r.steps = std::lround(s.settle / (nu * k1 * k1));
  r.window_steps = std::lround(std::pow(s.window * L, 2) / nu);
  r.T_window = double(r.window_steps) / r.t_nu;
  if (r.window_steps > r.steps) r.steps = r.window_steps;

  lbm::LbmSetup ls;
  ls.lattice = lbm::LatticeKind::D3Q19;
  ls.precision = s.precision;
  ls.collision = lbm::CollisionKind::TRT;
  ls.tau = s.tau;
  ls.magic = r.magic;
  ls.domain.global = ls.domain.local = {r.L, r.L, r.L};
  const double fb = -r.F / V;
  ls.body_force = {fb, 0, 0};

  dem::HostParticles hp;
  // Centre on a cell centre (the fixed-sphere harness's placement).
  const double c = 0.5 * L + (r.L % 2 == 0 ? 0.5 : 0.0);
  hp.add({c, c, c}, a, s.ratio * rho);
  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {L, L, L};
  dp.periodic = {true, true, true};
  dp.body_force = {r.F, 0, 0};
  dp.external_forcing = true;
  dp.dt = 1.0;
  dp.material.stiffness = 20;
  dp.material.restitution = 0.9;
  imb::CoupledParams cp;
  cp.dem_substeps = 1;
  cp.slots = 2;
  cp.psm.weight = s.weight;
  cp.psm.map.method = imb::FractionMethod::Exact;
  cp.psm.map.max_radius = a;
  cp.psm.pipeline = imb::PsmPipeline::Mapped;
  imb::check_coupled_setup(ls, dp, hp, cp);

  auto fluid = lbm::make_lbm_solver(ls, b);
  const auto N = static_cast<std::size_t>(ls.domain.storage_cells());
  fluid->initialize(std::vector<std::uint8_t>(N, 0), std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  dem::DemSystem dem(Exec(b), dp, hp);
  imb::CoupledSolver cs(*fluid, dem, cp);
  r.cells = static_cast<long>(ls.domain.cells());

  const StartupReference ref(s.ratio);
  const double uT_phys = r.u_T * (1 + (s.ratio - 1) * r.phi), uT_psm = r.u_T * (1 + s.ratio * r.phi);
  r.T_end = double(r.steps) / r.t_nu;
  // The periodic-cube models on a grid of h = T_end / 2000 (at most 0.01).
  const double hb = std::min(0.01, r.T_end / 2000);
  const auto box_r = startup_periodic(s.ratio, L / a, r.T_end + 2 * hb, hb);
  const auto box_r1 = startup_periodic(s.ratio + 1, L / a, r.T_end + 2 * hb, hb);
  auto interp = [hb](const std::vector<double>& y, double T) {
    const double x = T / hb;
    const auto i = std::min(static_cast<std::size_t>(x), y.size() - 2);
    const double f = x - double(i);
    return (1 - f) * y[i] + f * y[i + 1];
  };
  const long every = std::max<long>(1, std::lround(r.t_nu / s.samples));
  const auto t0 = std::chrono::steady_clock::now();
  double s2 = 0, s2b = 0, s2bp = 0;
  long nall = 0;
  long nwin = 0;
  r.samples.push_back({});
  for (long n = 0; n < r.steps;) {
    const long k = std::min(every, r.steps - n);
    cs.advance(k);
    n += k;
    const auto h = dem.download();
    StartupSample q;
    q.step = n;
    q.T = double(n) / r.t_nu;
    q.v = h.v[0].x;
    const double ur = q.v - fb / rho * double(n);  // relative to the uniformly accelerated far fluid
    q.u = ur / uT_phys;
    q.u_psm = ur / uT_psm;
    q.ref = ref(q.T);
    q.box = interp(box_r, q.T);
    q.box_psm = interp(box_r1, q.T);
    q.in_window = n <= r.window_steps;
    if (!std::isfinite(q.v)) throw DivergenceError("startup: sphere velocity not finite at step " + std::to_string(n));
    if (q.in_window) {
      const double e = q.u - q.ref;
      s2 += e * e;
      r.max = std::max(r.max, std::abs(e));
      ++nwin;
    }
    const double eb = q.u - q.box, ebp = q.u_psm - q.box_psm;
    s2b += eb * eb;
    s2bp += ebp * ebp;
    r.max_box = std::max(r.max_box, std::abs(eb));
    r.max_box_psm = std::max(r.max_box_psm, std::abs(ebp));
    ++nall;
    r.samples.push_back(q);
  }
  fluid->synchronize();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.mlups = double(r.cells) * double(r.steps) / r.seconds / 1e6;
  r.rms = std::sqrt(s2 / std::max<long>(nwin, 1));
  r.rms_box = std::sqrt(s2b / std::max<long>(nall, 1));
  r.rms_box_psm = std::sqrt(s2bp / std::max<long>(nall, 1));
  r.v_end = r.samples.back().v;
  {
    const long n9 = std::lround(0.9 * double(r.steps));
    double v9 = 0;
    for (const auto& q : r.samples)
      if (q.step <= n9) v9 = q.v;
    r.late_change = std::abs(r.v_end - v9) / std::abs(r.v_end);
  }
  // The fluid's momentum sum c f excludes the half-force shift; the velocity
  // field's is sum c f + f_b / 2 per cell (rho = 1 to O(Ma^2)).
  const auto diag = fluid->diagnostics();
  r.J = diag.momentum[0] / V + 0.5 * fb;
  r.terminal = (r.v_end - r.J) / r.u_T;
  r.hasimoto = 1 / hasimoto_K(r.phi);
  r.sangani_acrivos = 1 / imb::sangani_acrivos_K(d / L);
  // Lab frame = the accelerated frame less the far fluid's a_b t (F / (rho V) per step).
  const double T = r.T_end, drift = 6 * M_PI * T / std::pow(L / a, 3);  // F t / (rho V) over u_T
  r.lab_end = r.v_end / r.u_T;
  r.lab_box = interp(box_r, T) * (1 + (s.ratio - 1) * r.phi) - drift;
  r.lab_box_psm = interp(box_r1, T) * (1 + s.ratio * r.phi) - drift;
  return r;
}

}  // namespace lbdem::bench
