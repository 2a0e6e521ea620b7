#pragma once
// A sphere near walls, resolved with partially saturated cells: the drag
// against the published wall corrections of wall_references.hpp (issue 29).
//
// Both cases are quasi-static Stokes problems: the sphere is held at one
// place and given a prescribed velocity V through the PSM's solid term (the
// slots carry V, first paper Eq. 2), the walls are at rest, and the drag at
// steady state depends only on the configuration (Re_p << 1). Inside the
// sphere the solid term holds the fluid at V, a uniform divergence-free flow
// whose normal velocity on the surface is V.n: the exterior sees exactly the
// boundary condition of a rigid sphere translating at V.
//
//  brenner: a box of W x W x H cells, periodic along x and y, half-way
//    bounce-back walls on both z faces (cells z = 0 and z = H - 1 are wall
//    cells; the wall planes are z = 1 and z = H - 1). The sphere (centre on a
//    cell centre in x and y) moves toward the lower wall with gap g (cells)
//    between its surface and the wall plane: centre z = 1 + a + g. Why these
//    faces: the code has no free-slip face, and any plane face at distance D
//    changes an unbounded sphere's drag by O(a/D); but a sphere near a wall
//    is screened by it (a Stokeslet normal to a no-slip wall and its image
//    decay like h^2 / r^3 at r >> h, Blake 1971), so the top wall and the
//    lateral images act on it only at O(a h^2 / H^3). The box's share is
//    measured by two box sizes.
//  tube: a circular tube of diameter D (axis along z, on a cell centre), its
//    wall PSM solid whose fraction in each cell is the exact area of the
//    cell's square outside the circle (no staircase); periodic along z with
//    length Lz. The sphere on the axis moves along it at V. Haberman & Sayre's
//    condition (fluid at rest far away: no net flow through the tube) is a
//    zero total flux: by linearity the case is two steady runs, A (sphere at
//    V, no body force: the sphere pumps fluid along the periodic tube) and B
//    (sphere at rest, body force g0 along z: the mean pressure gradient), and
//    the answer is A + s B with s = -Q_A / Q_B (Q the total flux, the
//    sphere's volume times V included). The sphere's force then includes the
//    mean pressure gradient's force on its volume (PsmOptions::
//    body_force_on_solid: the share B g of each covered cell). A disturbance
//    of Stokes flow in a tube decays along it like exp(-4.47 z / R) (the
//    first Papkovich-Fadle eigenvalue of the tube, Bungay & Brenner 1973), so
//    Lz = 2 D leaves e^-17.9 of an image's field at the sphere.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "core/error.hpp"
#include "imb/drag_error.hpp"
#include "imb/fixed_sphere.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/wall_lubrication.hpp"
#include "lbm/solver.hpp"
#include "wall_references.hpp"

namespace lbdem::bench {

// Area of the rectangle [x0, x1] x [y0, y1] inside the circle x^2 + y^2 <= R^2
// (exact: the integral over x of the chord's part in [y0, y1], with the
// antiderivative of sqrt(R^2 - x^2) where the chord ends inside).
inline double rect_circle_area(double x0, double x1, double y0, double y1, double R) {
  const double a = std::max(x0, -R), b = std::min(x1, R);
  if (a >= b || y0 >= y1) return 0.0;
  // S(x) = integral of sqrt(R^2 - x^2) from 0 to x.
  auto S = [R](double x) {
    const double t = std::clamp(x / R, -1.0, 1.0);
    return 0.5 * (x * std::sqrt(std::max(0.0, R * R - x * x)) + R * R * std::asin(t));
  };
  // I(y) = integral over [a, b] of clamp(y, -s(x), s(x)), s = sqrt(R^2 - x^2):
  // s(x) <= |y| for |x| >= c = sqrt(R^2 - y^2) (there the clamp is sign(y) s),
  // y itself for |x| < c.
  auto I = [&](double y) {
    if (std::abs(y) >= R) return (y > 0 ? 1.0 : -1.0) * (S(b) - S(a));
    const double c = std::sqrt(R * R - y * y);
    const double sg = y > 0 ? 1.0 : -1.0;
    double v = 0;
    // [a, b] split at -c and c.
    const double p0 = std::clamp(-c, a, b), p1 = std::clamp(c, a, b);
    v += sg * (S(p0) - S(a));
    v += y * (p1 - p0);
    v += sg * (S(b) - S(p1));
    return v;
  };
  return std::max(0.0, I(y1) - I(y0));
}

struct WallCaseSpec {
  double diameter = 10;   // d / l
  double tau = 0.8;
  double magic = -1;      // TRT Lambda; < 0: imb::psm_magic_auto(d, tau) (the default case's `magic: auto`)
  imb::PsmWeight weight = imb::PsmWeight::NobleTorczynskiWall;
  lbm::Precision precision = lbm::Precision::FP64;
  double re = 0.1;        // Re_p = U d / nu of the prescribed speed U
  double tolerance = 1e-5;  // steady state: estimated remaining relative change of the drag (and flux)
  long max_steps = 400000;
  long check = 0;         // steps between checks; 0: from the box (about W^2 / (40 nu), at least 50)
  // brenner: the z faces as PSM solid (cells z = 0 and H - 1 fully covered,
  // at rest, z periodic) instead of half-way bounce-back: the same wall plane
  // z = 1 by another operator, to tell the wall's share of an error from the
  // sphere's.
  bool psm_wall = false;
  // brenner: the engine's gap correction (psm.wall_lubrication: on, the
  // coupled step's kernel imb::add_wall_lubrication with the setting
  // imb::resolve_wall_lubrication gives at this tau, Lambda and weighting)
  // added to the gathered force at every read, as the coupled step adds it:
  // BrennerResult::F_engine. Off: the bench's own correction only
  // (BrennerResult::lubrication, added to the normalised drag), as before.
  bool engine_lubrication = false;
};

// One steady run of a sphere held at `centre` with velocity `velocity` in a
// box with optional wall flags and an optional fixed solid at rest (per
// storage cell ε, e.g. the tube).
struct WallRun {
  std::array<double, 3> force{0, 0, 0};  // hydrodynamic force on the sphere (lattice units)
  std::array<double, 3> force_engine{0, 0, 0};  // with the engine's gap correction (WallScene::lubrication; else = force)
  double flux = 0;         // total volume flux along `axis` times the length (sum over cells, sphere's V included)
  long steps = 0;
  bool converged = false;
  double remaining = 1, seconds = 0, mlups = 0;
  long cells = 0;
};

struct WallScene {
  std::array<long, 3> dims{16, 16, 16};
  std::vector<std::uint8_t> wall;        // per owned cell (x fastest): 1 bounce-back wall; empty: none
  std::vector<double> solid;             // per owned cell: ε of a solid at rest; empty: none
  std::array<double, 3> centre{8, 8, 8};
  std::array<double, 3> velocity{0, 0, 0};
  std::array<double, 3> body_force{0, 0, 0};
  int axis = 2;                          // force and flux component watched
  bool track_flux = false;               // steady state also on the flux
  // The engine's wall gap correction (imb/wall_lubrication.hpp), added to the
  // sphere's gathered force by the coupled step's kernel at each read; the
  // steady state is watched on the bare force (the same steps either way).
  const imb::WallLubricationParams* lubrication = nullptr;
};

inline WallRun run_wall_scene(const WallCaseSpec& s, const WallScene& sc, Backend b) {
  const double a = 0.5 * s.diameter, nu = (s.tau - 0.5) / 3.0;
  lbm::LbmSetup ls;
  ls.lattice = lbm::LatticeKind::D3Q19;
  ls.precision = s.precision;
  ls.collision = lbm::CollisionKind::TRT;
  ls.tau = s.tau;
  ls.magic = s.magic >= 0 ? s.magic : imb::psm_magic_auto(s.diameter, s.tau);
  ls.domain.global = ls.domain.local = sc.dims;
  ls.body_force = sc.body_force;
  if (!sc.wall.empty()) {
    ls.boundaries.count = 1;
    ls.boundaries.kind[0] = lbm::BoundaryKind::Wall;
  }
  auto solver = lbm::make_lbm_solver(ls, b);
  const auto Ns = static_cast<std::size_t>(ls.domain.storage_cells());
  const GridView gv = ls.domain.view();
  const CellBox own = ls.domain.owned();
  std::vector<std::uint8_t> flags(Ns, lbm::kGhostFlag);
  std::vector<long> owned_of(Ns, -1);  // storage cell -> owned index (x fastest), -1 for ghosts
  for (Index t = 0; t < own.size(); ++t) {
    int x, y, z;
    own.coords(t, x, y, z);
    const auto i = static_cast<std::size_t>(gv.index(x, y, z));
    flags[i] = sc.wall.empty() ? 0 : sc.wall[static_cast<std::size_t>(t)];
    owned_of[i] = static_cast<long>(t);
  }
  solver->initialize(flags, std::vector<double>(Ns, 1.0), std::vector<double>(3 * Ns, 0.0));

  std::vector<double> host(10, 0.0);
  host[0] = sc.centre[0];
  host[1] = sc.centre[1];
  host[2] = sc.centre[2];
  host[3] = a;
  host[4] = sc.velocity[0];
  host[5] = sc.velocity[1];
  host[6] = sc.velocity[2];
  Buffer<double> pd(b, 10);
  pd.copy_from_host(host);
  imb::PsmParticles p;
  double* dp = pd.data();
  p.x = dp; p.y = dp + 1; p.z = dp + 2; p.r = dp + 3;
  p.vx = dp + 4; p.vy = dp + 5; p.vz = dp + 6; p.wx = dp + 7; p.wy = dp + 8; p.wz = dp + 9;
  p.n = 1;
  const int K = 2;
  imb::PsmCoupling coupling(*solver, K);
  imb::PsmOptions opt;
  opt.variant = imb::PsmVariant::NEBB;
  opt.weight = s.weight;
  opt.map.method = imb::FractionMethod::Exact;
  opt.map.max_radius = a;
  opt.pipeline = imb::PsmPipeline::Mapped;
  // The mean pressure gradient (body force) acts on the sphere's volume too.
  opt.body_force_on_solid = true;
  coupling.map(p, opt, true);
  const auto eps_sphere = coupling.slots().total_eps_host();
  // The fixed solid (tube) is added to the mapped slots once: one more slot in
  // each cell it touches, velocity 0, particle index 1 (no particle: the
  // gather of particle 0 never reads it).
  if (!sc.solid.empty()) {
    const imb::CellSlotsView v = coupling.slots().view();
    const auto nc = static_cast<std::size_t>(v.ncells);
    std::vector<int> cnt(nc), par(nc * K);
    std::vector<double> eps(nc * K);
    std::vector<float> vel(nc * K * 3);
    backend_copy_to_host(b, cnt.data(), v.count, cnt.size() * sizeof(int));
    backend_copy_to_host(b, par.data(), v.particle, par.size() * sizeof(int));
    backend_copy_to_host(b, eps.data(), v.eps, eps.size() * sizeof(double));
    backend_copy_to_host(b, vel.data(), v.vel, vel.size() * sizeof(float));
    for (std::size_t c = 0; c < nc; ++c) {
      if (owned_of[c] < 0) continue;
      const double e = sc.solid[static_cast<std::size_t>(owned_of[c])];
      if (e <= 0) continue;
      if (eps_sphere[c] > 0)
        throw ConfigError("wall case: the sphere and the fixed solid share a cell (make the tube wider)");
      const int k = cnt[c];
      if (k >= K) throw ConfigError("wall case: no slot left for the fixed solid");
      par[static_cast<std::size_t>(k) * nc + c] = 1;
      eps[static_cast<std::size_t>(k) * nc + c] = std::min(1.0, e);
      for (int ax = 0; ax < 3; ++ax) vel[(static_cast<std::size_t>(ax) * K + k) * nc + c] = 0.0f;
      cnt[c] = k + 1;
    }
    backend_copy_from_host(b, v.count, cnt.data(), cnt.size() * sizeof(int));
    backend_copy_from_host(b, v.particle, par.data(), par.size() * sizeof(int));
    backend_copy_from_host(b, v.eps, eps.data(), eps.size() * sizeof(double));
    backend_copy_from_host(b, v.vel, vel.data(), vel.size() * sizeof(float));
  }
  const auto eps_tot = coupling.slots().total_eps_host();
  {  // start: fluid at rest, the sphere's cells at V in proportion to their cover
    std::vector<double> u0(3 * Ns, 0.0);
    for (std::size_t i = 0; i < Ns; ++i)
      for (int ax = 0; ax < 3; ++ax) u0[3 * i + ax] = sc.velocity[ax] * std::min(1.0, eps_sphere[i]);
    solver->initialize(flags, std::vector<double>(Ns, 1.0), u0);
  }
  const int ax = sc.axis;
  // Total flux along the axis over the box: the fluid's share (1 - ε) u of
  // each open cell plus the sphere's ε V.
  auto flux = [&] {
    std::vector<double> rho, u;
    solver->macroscopic(rho, u);
    double q = 0;
    for (std::size_t i = 0; i < Ns; ++i)
      if (owned_of[i] >= 0 && flags[i] == 0)
        q += (1.0 - std::min(1.0, eps_tot[i])) * u[3 * i + ax] + std::min(1.0, eps_sphere[i]) * sc.velocity[ax];
    return q;
  };
  const double W = double(std::min(sc.dims[0], sc.dims[1]));
  const long check = s.check > 0 ? s.check : std::max<long>(50, std::lround(W * W / (40 * nu)));
  Buffer<double> f6(b, 6);
  WallRun r;
  r.cells = static_cast<long>(own.size());
  const auto t0 = std::chrono::steady_clock::now();
  // Steady state as in run_fixed_sphere: a quantity approaching its limit
  // like A e^{-t/T}; remaining change = D q / (1 - q), D the change over a
  // check, q the ratio of successive changes.
  struct Watch {
    double prev = 0, prev_delta = 0, remaining = 1;
    void add(double v, long step, long check) {
      const double delta = std::abs(v - prev);
      if (step >= 4 * check && prev_delta > 0) {
        const double q = std::min(delta / prev_delta, 0.999);
        remaining = delta * std::max(1.0, q / (1 - q)) / std::max(std::abs(v), 1e-300);
      }
      prev_delta = step >= 2 * check ? delta : 0;
      prev = v;
    }
  } wf, wq;
  long step = 0;
  std::array<double, 3> last_bare{0, 0, 0};
  while (step < s.max_steps) {
    for (long k = 0; k < check; ++k)
      coupling.step(p, opt, k == check - 1 ? imb::ForceOut::six(f6.data()) : imb::ForceOut{});
    step += check;
    const auto f = f6.to_vector();
    if (sc.lubrication) {  // the engine's correction on the force just gathered (the sphere: particle 0)
      imb::add_wall_lubrication(Exec(b), *sc.lubrication, p, 1, f6.data(), 6);
      const auto fe = f6.to_vector();
      r.force_engine = {fe[0], fe[1], fe[2]};
    } else {
      r.force_engine = {f[0], f[1], f[2]};
    }
    if (!std::isfinite(f[ax])) throw DivergenceError("wall case: drag not finite at step " + std::to_string(step));
    last_bare = {f[0], f[1], f[2]};
    wf.add(f[ax], step, check);
    r.remaining = wf.remaining;
    if (sc.track_flux) {
      wq.add(flux(), step, check);
      r.remaining = std::max(r.remaining, wq.remaining);
    }
    if (step >= 4 * check && r.remaining < s.tolerance) {
      r.converged = true;
      break;
    }
  }
  solver->synchronize();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.steps = step;
  r.mlups = double(r.cells) * double(step) / r.seconds / 1e6;
  if (!sc.lubrication) {
    const auto f = f6.to_vector();
    r.force = {f[0], f[1], f[2]};
  } else {
    r.force = last_bare;
  }
  r.flux = flux();
  return r;
}

// The same sphere's drag unbounded, relative to Stokes's 3 pi mu d U: its
// drag coefficient in a simple cubic array of period d / chi (the
// fixed-sphere harness: same d, tau, Lambda and weighting, exact fractions,
// centre on a cell centre) over Sangani & Acrivos's K at that chi. What the
// array's K misses is the sphere's own discretisation error (its effective
// radius); the wall cases divide it out. (The harness holds the sphere and
// drives the fluid; the wall cases move the sphere: the two frames differ
// by about 0.3 % at d/l 8, bench/imb/NOTES.md.)
inline double unbounded_factor(const WallCaseSpec& s, double chi, Backend b) {
  imb::FixedSphereSpec f;
  f.dim = 3;
  f.diameter = s.diameter;
  f.chi = chi;
  f.re_p = s.re;
  f.tau = s.tau;
  f.magic = s.magic >= 0 ? s.magic : imb::psm_magic_auto(s.diameter, s.tau);
  f.precision = s.precision;
  f.weight = s.weight;
  f.tolerance = s.tolerance;
  const auto r = imb::run_fixed_sphere(f, b);
  return r.K / r.K_ref;
}

// Brenner's case: the sphere moving toward the lower wall at U with gap g
// (cells) in a box of W x W x H cells (see the top of the file).
struct BrennerResult {
  WallRun run;
  double h_over_a = 0, lambda = 0;  // Brenner's lambda(h / a)
  double F = 0;                     // drag (opposing the motion), lattice units
  double F_stokes = 0;              // 3 pi mu d U
  double U = 0;
  double lubrication = 0;           // the gap correction's share of lambda (imb::wall_lubrication_lambda; 0 outside its Lambda range)
  double F_engine = 0;              // engine_lubrication: the drag with the engine's correction (else F)
  imb::WallLubricationSetting engine;  // engine_lubrication: the setting the engine resolves here
};

inline BrennerResult run_brenner(const WallCaseSpec& s, long W, long H, double gap, Backend b) {
  const double d = s.diameter, a = 0.5 * d, nu = (s.tau - 0.5) / 3.0;
  const double zc = 1.0 + a + gap;
  if (gap < 0.5 || zc + a > double(H - 1) - 1.0)
    throw ConfigError("brenner: gap " + std::to_string(gap) + " cells: must be >= 0.5 and leave the sphere a cell "
                      "below the top wall of the box (H = " + std::to_string(H) + ")");
  if (double(W) < d + 4)
    throw ConfigError("brenner: box width " + std::to_string(W) + " cells: must be at least d + 4");
  WallScene sc;
  sc.dims = {W, W, H};
  auto set_faces = [&](auto& faces) {
    faces.assign(static_cast<std::size_t>(W * W * H), 0);
    for (long y = 0; y < W; ++y)
      for (long x = 0; x < W; ++x) {
        faces[static_cast<std::size_t>(x + W * y)] = 1;
        faces[static_cast<std::size_t>(x + W * (y + W * (H - 1)))] = 1;
      }
  };
  if (s.psm_wall) set_faces(sc.solid);
  else set_faces(sc.wall);
  // On a cell centre in x and y (0.5 from the box centre when W is even).
  const double cxy = 0.5 * double(W) + (W % 2 == 0 ? 0.5 : 0.0);
  BrennerResult r;
  r.U = s.re * nu / d;
  sc.centre = {cxy, cxy, zc};
  sc.velocity = {0, 0, -r.U};
  sc.axis = 2;
  const double magic = s.magic >= 0 ? s.magic : imb::psm_magic_auto(d, s.tau);
  if (s.engine_lubrication) {
    // The walls as a case declares them: the closed z axis of a W x W x H
    // grid (planes z = 1 and H - 1), the run's tau, Lambda and weighting,
    // NEBB and exact fractions (run_wall_scene's), fluid density 1.
    imb::LubricationWall walls[imb::kMaxLubricationWalls];
    const int nw = imb::closed_box_walls(Grid::whole({W, W, H}, {true, true, false}), 3, walls);
    r.engine = imb::resolve_wall_lubrication(true, 3, s.tau, true, magic, s.weight, imb::PsmVariant::NEBB,
                                             imb::FractionMethod::Exact, 1.0, walls, nw);
    if (r.engine.applied) sc.lubrication = &r.engine.k;
  }
  r.run = run_wall_scene(s, sc, b);
  r.F = r.run.force[2];  // the fluid pushes back along +z
  r.F_engine = r.run.force_engine[2];
  r.F_stokes = 3 * M_PI * nu * d * r.U;
  r.h_over_a = (zc - 1.0) / a;
  r.lambda = brenner_lambda(r.h_over_a);
  r.lubrication = imb::wall_lubrication_lambda(a, gap, magic);
  return r;
}

// Haberman & Sayre's case: the sphere on the axis of a tube of diameter
// D = d / k, periodic length Lz = length * D (see the top of the file).
struct TubeResult {
  WallRun a, b;               // run A (sphere at U) and run B (sphere at rest, body force g0)
  double F = 0;               // drag of the zero-flux combination (opposing the motion)
  double F_stokes = 0;        // 3 pi mu d U
  double K = 0, K_ref = 0;    // F / F_stokes and Haberman & Sayre's K(k)
  double U = 0, g = 0;        // the speed and the zero-flux body force
  double k = 0, D = 0;
  long W = 0, Lz = 0;
};

inline TubeResult run_tube(const WallCaseSpec& s, double k, double length, Backend b) {
  if (!(k > 0 && k <= 0.5)) throw ConfigError("tube: k = d/D = " + std::to_string(k) + ": must be in (0, 0.5]");
  const double d = s.diameter, nu = (s.tau - 0.5) / 3.0;
  TubeResult r;
  r.k = k;
  r.D = d / k;
  const double R = 0.5 * r.D;
  // Odd width: the axis on a cell centre; at least one whole solid cell around the circle.
  r.W = 2 * static_cast<long>(std::ceil(R + 1.0)) + 1;
  r.Lz = std::max<long>(static_cast<long>(std::lround(length * r.D)), static_cast<long>(std::ceil(d)) + 4);
  const double c = 0.5 * double(r.W);
  WallScene sc;
  sc.dims = {r.W, r.W, r.Lz};
  std::vector<double> plane(static_cast<std::size_t>(r.W * r.W));
  for (long y = 0; y < r.W; ++y)
    for (long x = 0; x < r.W; ++x)
      plane[static_cast<std::size_t>(x + r.W * y)] =
          1.0 - rect_circle_area(double(x) - c, double(x) + 1 - c, double(y) - c, double(y) + 1 - c, R);
  sc.solid.resize(static_cast<std::size_t>(r.W * r.W * r.Lz));
  for (long z = 0; z < r.Lz; ++z)
    std::copy(plane.begin(), plane.end(), sc.solid.begin() + static_cast<std::ptrdiff_t>(z * r.W * r.W));
  sc.centre = {c, c, 0.5 * double(r.Lz) + (r.Lz % 2 == 0 ? 0.5 : 0.0)};
  sc.axis = 2;
  sc.track_flux = true;
  r.U = s.re * nu / d;
  // Run A: the sphere at U, no body force.
  sc.velocity = {0, 0, r.U};
  r.a = run_wall_scene(s, sc, b);
  // Run B: the sphere at rest, a body force of the size that drives a mean
  // flow of about U through the open tube (Poiseuille: mean = g R^2 / (8 mu)).
  const double g0 = 8 * nu * r.U / (R * R);
  sc.velocity = {0, 0, 0};
  sc.body_force = {0, 0, g0};
  r.b = run_wall_scene(s, sc, b);
  const double sB = -r.a.flux / r.b.flux;
  r.g = sB * g0;
  // Force on the fluid from the sphere = -(force on the sphere); the drag opposes +z.
  r.F = -(r.a.force[2] + sB * r.b.force[2]);
  r.F_stokes = 3 * M_PI * nu * d * r.U;
  r.K = r.F / r.F_stokes;
  r.K_ref = haberman_sayre_K(k);
  return r;
}

}  // namespace lbdem::bench
