// Gas solver kernels and the step (cfd/gas_solver.hpp).
#include "cfd/gas_solver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "core/checkpoint.hpp"

namespace lbdem::cfd {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct FaceBCView {
  int kind;  // FaceKind
  double inflow, patch_inflow, pressure;
  bool patch;
  double lo[2], hi[2];
};

// Everything a gas kernel reads or writes (trivially copyable).
struct GasView {
  GasGridView g;
  FaceBCView bc[6];
  double* u[3];
  double* uh[3];
  double* af[3];
  double* eps;
  double* eps_old;
  double* p;
  double* B;      // dt beta / rho per cell
  double* BV[3];  // dt beta v_s / rho per cell [m/s]
  double* uc[3];
  double* gp[3];
  double dt, rho, nu;
  double grav[3];

  LBDEM_HD int fext(int a, int d) const { return g.n[d] + (d == a ? 1 : 0); }
  LBDEM_HD Index face(int a, int i, int j, int k) const {
    return i + static_cast<Index>(fext(a, 0)) * (j + static_cast<Index>(fext(a, 1)) * k);
  }
  LBDEM_HD Index face(int a, const int f[3]) const { return face(a, f[0], f[1], f[2]); }
  LBDEM_HD Index cell(const int c[3]) const { return g.index(c[0], c[1], c[2]); }
  LBDEM_HD int kind(int side) const { return bc[side].kind; }
  LBDEM_HD bool is_boundary_face(int a, int fa) const { return !g.periodic[a] && (fa == 0 || fa == g.n[a]); }
  // Inlet superficial speed at the centre of boundary face f of axis a.
  LBDEM_HD double inlet_speed(int a, int side, const int f[3]) const {
    const FaceBCView& b = bc[side];
    if (!b.patch) return b.inflow;
    int t = 0;
    bool in = true;
    for (int d = 0; d < 3; ++d) {
      if (d == a) continue;
      const double x = g.origin[d] + (f[d] + 0.5) * g.h;
      if (x < b.lo[t] || x > b.hi[t]) in = false;
      ++t;
    }
    return in ? b.patch_inflow : b.inflow;
  }
};

// Velocity of axis-a faces at face coords f, with f[b] possibly one outside
// the box along a tangential axis b: wrap, or the ghost value of the face
// kind (no-slip and inlet: tangential velocity zero at the face; free-slip
// and outlet: zero gradient).
LBDEM_HD inline double face_u_tangential(const GasView& v, int a, int f[3], int b, double u0) {
  const int fb = f[b];
  if (fb >= 0 && fb < v.g.n[b]) return v.u[a][v.face(a, f)];
  if (v.g.periodic[b]) {
    f[b] = fb < 0 ? fb + v.g.n[b] : fb - v.g.n[b];
    const double r = v.u[a][v.face(a, f)];
    f[b] = fb;
    return r;
  }
  const int k = v.kind(2 * b + (fb < 0 ? 0 : 1));
  return (k == static_cast<int>(FaceKind::NoSlipWall) || k == static_cast<int>(FaceKind::Inlet)) ? -u0 : u0;
}

LBDEM_HD inline int wrap(int i, int n) { return i < 0 ? i + n : (i >= n ? i - n : i); }

// Predictor on the faces of axis A (one thread per face of the face box).
// Writes only u^ and the pressure coefficient: u itself is read by the
// neighbours and changes in Correct.
template <int A>
struct Predictor {
  GasView v;
  LBDEM_HD void operator()(Index t) const {
    int f[3];
    const int m0 = v.fext(A, 0), m1 = v.fext(A, 1);
    f[0] = static_cast<int>(t % m0);
    f[1] = static_cast<int>((t / m0) % m1);
    f[2] = static_cast<int>(t / (static_cast<Index>(m0) * m1));
    const int nA = v.g.n[A];
    const Index fi = v.face(A, f);
    const double h = v.g.h;
    if (v.is_boundary_face(A, f[A])) {
      const bool hi = f[A] == nA;
      const int side = 2 * A + (hi ? 1 : 0);
      int c[3] = {f[0], f[1], f[2]};
      c[A] = hi ? nA - 1 : 0;
      const Index ci = v.cell(c);
      const int k = v.kind(side);
      if (k == static_cast<int>(FaceKind::Inlet)) {
        const double un = (hi ? -1.0 : 1.0) * v.inlet_speed(A, side, f) / v.eps[ci];
        v.uh[A][fi] = un;
        v.af[A][fi] = 0;
      } else if (k == static_cast<int>(FaceKind::Outlet)) {
        int fn[3] = {f[0], f[1], f[2]};
        fn[A] = hi ? nA - 1 : 1;
        // Zero normal gradient of u, with gravity and the drag of the
        // adjacent cell (so a hydrostatic or fixed-bed column is exact up to
        // the outlet).
        const double e = v.eps[ci];
        const double denom = 1.0 + v.B[ci] / e;
        v.uh[A][fi] = (v.u[A][v.face(A, fn)] + v.dt * v.grav[A] + v.BV[A][ci] / e) / denom;
        v.af[A][fi] = 2.0 * e * v.dt / (v.rho * denom) / (h * h);
      } else {
        v.uh[A][fi] = 0;
        v.af[A][fi] = 0;
      }
      return;
    }
    if (v.g.periodic[A] && f[A] == nA) {
      v.uh[A][fi] = 0;
      v.af[A][fi] = 0;
      return;
    }
    // Cells on either side.
    int cl[3] = {f[0], f[1], f[2]}, cr[3] = {f[0], f[1], f[2]};
    cl[A] = wrap(f[A] - 1, nA);
    const Index L = v.cell(cl), R = v.cell(cr);
    const double ef = 0.5 * (v.eps[L] + v.eps[R]);
    const double Bf = 0.5 * (v.B[L] + v.B[R]);
    const double BVf = 0.5 * (v.BV[A][L] + v.BV[A][R]);
    const double u0 = v.u[A][fi];
    double adv = 0, lap = 0;
    for (int b = 0; b < 3; ++b) {
      double um, up, vel;
      int g[3] = {f[0], f[1], f[2]};
      if (b == A) {
        g[A] = v.g.periodic[A] ? wrap(f[A] - 1, nA) : f[A] - 1;
        um = v.u[A][v.face(A, g)];
        g[A] = v.g.periodic[A] ? wrap(f[A] + 1, nA) : f[A] + 1;
        up = v.u[A][v.face(A, g)];
        vel = u0;
      } else {
        g[b] = f[b] - 1;
        um = face_u_tangential(v, A, g, b, u0);
        g[b] = f[b] + 1;
        up = face_u_tangential(v, A, g, b, u0);
        // Velocity component b at this face: mean of the four b-faces of
        // cells L and R.
        const int nb = v.g.n[b];
        int q[3];
        double s = 0;
        for (int side = 0; side < 2; ++side) {
          const int* c = side == 0 ? cl : cr;
          q[0] = c[0]; q[1] = c[1]; q[2] = c[2];
          s += v.u[b][v.face(b, q)];
          q[b] = c[b] + 1;
          if (v.g.periodic[b] && q[b] == nb) q[b] = 0;
          s += v.u[b][v.face(b, q)];
        }
        vel = 0.25 * s;
      }
      adv += vel > 0 ? vel * (u0 - um) / h : vel * (up - u0) / h;
      lap += (up - 2.0 * u0 + um) / (h * h);
    }
    const double rhs = u0 + v.dt * (-adv + v.nu * lap + v.grav[A]) + BVf / ef;
    const double denom = 1.0 + Bf / ef;
    v.uh[A][fi] = rhs / denom;
    v.af[A][fi] = ef * v.dt / (v.rho * denom) / (h * h);
  }
};

// Gas fraction at face f of axis a as the flux uses it: the mean of the two
// cells, or the adjacent cell's at a boundary face.
LBDEM_HD inline double face_eps(const GasView& v, int a, const int c[3], bool hi_face) {
  int o[3] = {c[0], c[1], c[2]};
  o[a] += hi_face ? 1 : -1;
  if (o[a] < 0 || o[a] >= v.g.n[a]) {
    if (!v.g.periodic[a]) return v.eps[v.cell(c)];
    o[a] = wrap(o[a], v.g.n[a]);
  }
  return 0.5 * (v.eps[v.cell(c)] + v.eps[v.cell(o)]);
}

LBDEM_HD inline Index hi_face_index(const GasView& v, int a, const int c[3]) {
  int f[3] = {c[0], c[1], c[2]};
  f[a] += 1;
  if (v.g.periodic[a] && f[a] == v.g.n[a]) f[a] = 0;
  return v.face(a, f);
}

// Right-hand side of the pressure equation, per cell.
struct PressureRhs {
  GasView v;
  double* rhs;
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    v.g.coords(ci, c[0], c[1], c[2]);
    double div = 0, dir = 0;
    for (int a = 0; a < 3; ++a) {
      const Index lo = v.face(a, c), hi = hi_face_index(v, a, c);
      div += face_eps(v, a, c, true) * v.uh[a][hi] - face_eps(v, a, c, false) * v.uh[a][lo];
      if (!v.g.periodic[a]) {
        if (c[a] == 0 && v.kind(2 * a) == static_cast<int>(FaceKind::Outlet)) dir += v.af[a][lo] * v.bc[2 * a].pressure;
        if (c[a] == v.g.n[a] - 1 && v.kind(2 * a + 1) == static_cast<int>(FaceKind::Outlet))
          dir += v.af[a][hi] * v.bc[2 * a + 1].pressure;
      }
    }
    rhs[ci] = -(div / v.g.h + (v.eps[ci] - v.eps_old[ci]) / v.dt) + dir;
  }
};

// u = u^ - c grad p on the faces of axis A.
template <int A>
struct Correct {
  GasView v;
  LBDEM_HD void operator()(Index t) const {
    int f[3];
    const int m0 = v.fext(A, 0), m1 = v.fext(A, 1);
    f[0] = static_cast<int>(t % m0);
    f[1] = static_cast<int>((t / m0) % m1);
    f[2] = static_cast<int>(t / (static_cast<Index>(m0) * m1));
    const int nA = v.g.n[A];
    const Index fi = v.face(A, f);
    const double h = v.g.h;
    if (v.is_boundary_face(A, f[A])) {
      const bool hi = f[A] == nA;
      const int side = 2 * A + (hi ? 1 : 0);
      if (v.kind(side) != static_cast<int>(FaceKind::Outlet)) {
        v.u[A][fi] = v.uh[A][fi];  // wall or inlet: the prescribed value
        return;
      }
      int c[3] = {f[0], f[1], f[2]};
      c[A] = hi ? nA - 1 : 0;
      const Index ci = v.cell(c);
      const double pc = v.p[ci], po = v.bc[side].pressure;
      const double dp = hi ? po - pc : pc - po;
      v.u[A][fi] = v.uh[A][fi] - v.af[A][fi] * h * dp / v.eps[ci];
      return;
    }
    if (v.g.periodic[A] && f[A] == nA) return;  // the same face as 0
    int cl[3] = {f[0], f[1], f[2]}, cr[3] = {f[0], f[1], f[2]};
    cl[A] = wrap(f[A] - 1, nA);
    const Index L = v.cell(cl), R = v.cell(cr);
    const double ef = 0.5 * (v.eps[L] + v.eps[R]);
    v.u[A][fi] = v.uh[A][fi] - v.af[A][fi] * h * (v.p[R] - v.p[L]) / ef;
  }
};

// Cell-centred velocity and pressure gradient.
struct CellFields {
  GasView v;
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    v.g.coords(ci, c[0], c[1], c[2]);
    const double h = v.g.h;
    for (int a = 0; a < 3; ++a) {
      const Index lo = v.face(a, c), hi = hi_face_index(v, a, c);
      v.uc[a][ci] = 0.5 * (v.u[a][lo] + v.u[a][hi]);
      // Face gradients: across interior faces; at an outlet over the half
      // cell; at a wall or inlet none (the cell uses its other face).
      double gl = 0, gh = 0;
      bool hl = false, hh = false;
      int o[3] = {c[0], c[1], c[2]};
      if (c[a] > 0 || v.g.periodic[a]) {
        o[a] = wrap(c[a] - 1, v.g.n[a]);
        gl = (v.p[ci] - v.p[v.cell(o)]) / h;
        hl = true;
      } else if (v.kind(2 * a) == static_cast<int>(FaceKind::Outlet)) {
        gl = (v.p[ci] - v.bc[2 * a].pressure) / (0.5 * h);
        hl = true;
      }
      if (c[a] < v.g.n[a] - 1 || v.g.periodic[a]) {
        o[a] = wrap(c[a] + 1, v.g.n[a]);
        gh = (v.p[v.cell(o)] - v.p[ci]) / h;
        hh = true;
      } else if (v.kind(2 * a + 1) == static_cast<int>(FaceKind::Outlet)) {
        gh = (v.bc[2 * a + 1].pressure - v.p[ci]) / (0.5 * h);
        hh = true;
      }
      v.gp[a][ci] = hl && hh ? 0.5 * (gl + gh) : (hl ? gl : (hh ? gh : 0.0));
    }
  }
};

struct GasFraction {
  const double* solid;
  double* eps;
  double floor;
  LBDEM_HD void operator()(Index c) const {
    const double e = 1.0 - solid[c];
    eps[c] = e > floor ? e : floor;
  }
};

// Per particle: gamma from the interpolated gas velocity and solid fraction,
// deposited as dt gamma / (rho V_c) and dt gamma v / (rho V_c).
struct DragDeposit {
  GasView v;
  Deposition scheme;
  DragParams drag;
  const double* solid;
  double max_phi;
  dem::ParticleView p;
  double* gamma;
  unsigned long long* acc;
  LBDEM_HD void operator()(Index i) const {
    const dem::Real4 pr = p.pos_r[i];
    const Vec3d x = dem::xyz(pr);
    const Vec3d vel = p.vel_im ? dem::xyz(p.vel_im[i]) : Vec3d{0, 0, 0};
    const Stencil3D s = stencil_3d(v.g, scheme, x);
    double phi = 0, ug[3] = {0, 0, 0};
    for (int t = 0; t < s.size(); ++t) {
      Index c;
      double w;
      s.entry(v.g, t, c, w);
      phi += w * solid[c];
      for (int a = 0; a < 3; ++a) ug[a] += w * v.uc[a][c];
    }
    phi = phi < max_phi ? phi : max_phi;
    const Vec3d slip{ug[0] - vel.x, ug[1] - vel.y, ug[2] - vel.z};
    const double gm = drag_gamma(drag, phi, 2.0 * pr.w, norm(slip));
    gamma[i] = gm;
    const double q = v.dt * gm / (v.rho * v.g.volume()) * kFixedScale;
    const Index nc = v.g.cells();
    deposit_fixed(v.g, s, q, acc);
    deposit_fixed(v.g, s, q * vel.x, acc + nc);
    deposit_fixed(v.g, s, q * vel.y, acc + 2 * nc);
    deposit_fixed(v.g, s, q * vel.z, acc + 3 * nc);
  }
};

struct DragFields {
  const unsigned long long* acc;
  double* B;
  double* BV0;
  double* BV1;
  double* BV2;
  Index nc;
  LBDEM_HD void operator()(Index c) const {
    B[c] = static_cast<double>(static_cast<long long>(acc[c])) * kFixedQuantum;
    BV0[c] = static_cast<double>(static_cast<long long>(acc[c + nc])) * kFixedQuantum;
    BV1[c] = static_cast<double>(static_cast<long long>(acc[c + 2 * nc])) * kFixedQuantum;
    BV2[c] = static_cast<double>(static_cast<long long>(acc[c + 3 * nc])) * kFixedQuantum;
  }
};

// Set I force on each particle: drag at the new gas velocity plus -V_p grad p.
struct ParticleForce {
  GasView v;
  Deposition scheme;
  dem::ParticleView p;
  const double* gamma;
  LBDEM_HD void operator()(Index i) const {
    const dem::Real4 pr = p.pos_r[i];
    const Vec3d vel = p.vel_im ? dem::xyz(p.vel_im[i]) : Vec3d{0, 0, 0};
    const Stencil3D s = stencil_3d(v.g, scheme, dem::xyz(pr));
    double ug[3] = {0, 0, 0}, gp[3] = {0, 0, 0};
    for (int t = 0; t < s.size(); ++t) {
      Index c;
      double w;
      s.entry(v.g, t, c, w);
      for (int a = 0; a < 3; ++a) {
        ug[a] += w * v.uc[a][c];
        gp[a] += w * v.gp[a][c];
      }
    }
    const double vp = 4.0 / 3.0 * kPi * pr.w * pr.w * pr.w;
    const double gm = gamma[i];
    p.ext_force[i] = dem::Real4{gm * (ug[0] - vel.x) - vp * gp[0], gm * (ug[1] - vel.y) - vp * gp[1],
                                gm * (ug[2] - vel.z) - vp * gp[2], 0.0};
  }
};

struct Fill {
  double* x;
  double value;
  LBDEM_HD void operator()(Index i) const { x[i] = value; }
};

struct CopyCells {
  const double* from;
  double* to;
  LBDEM_HD void operator()(Index i) const { to[i] = from[i]; }
};

Index face_count(const GasGridView& g, int a) {
  Index n = 1;
  for (int d = 0; d < 3; ++d) n *= g.n[d] + (d == a ? 1 : 0);
  return n;
}

}  // namespace

const char* to_string(FaceKind k) {
  switch (k) {
    case FaceKind::Periodic: return "periodic";
    case FaceKind::NoSlipWall: return "no_slip";
    case FaceKind::FreeSlipWall: return "free_slip";
    case FaceKind::Inlet: return "inlet";
    case FaceKind::Outlet: return "outlet";
  }
  return "?";
}

FaceKind parse_face_kind(const std::string& key, const std::string& value) {
  for (FaceKind k : {FaceKind::Periodic, FaceKind::NoSlipWall, FaceKind::FreeSlipWall, FaceKind::Inlet, FaceKind::Outlet})
    if (value == to_string(k)) return k;
  throw ConfigError(key + ": unknown boundary '" + value + "' (valid: periodic, no_slip, free_slip, inlet, outlet)");
}

void validate(const GasParams& p, const GasGridView& g, const GasKeys& keys, const std::string& where) {
  const std::string at = where.empty() ? "" : where + ": ";
  auto fail = [&](const std::string& key, double value, const std::string& valid) {
    std::ostringstream s;
    s << at << key << " = " << value << ": " << valid;
    throw ConfigError(s.str());
  };
  if (!(p.rho > 0)) fail(keys.rho, p.rho, "must be > 0 [kg/m^3]");
  if (!(p.mu > 0)) fail(keys.mu, p.mu, "must be > 0 [Pa s]");
  if (!(p.dt > 0)) fail(keys.dt, p.dt, "must be > 0 [s]");
  if (!(p.min_gas_fraction > 0 && p.min_gas_fraction < 1))
    fail(keys.min_gas_fraction, p.min_gas_fraction, "must lie in (0, 1)");
  if (p.cg_max_iterations < 1) fail(keys.cg_max_iterations, p.cg_max_iterations, "must be >= 1");
  if (!(p.cg_tolerance > 0)) fail(keys.cg_tolerance, p.cg_tolerance, "must be > 0");
  if (p.cg_poll_every < 1) fail(keys.cg_poll_every, p.cg_poll_every, "must be >= 1");
  if (p.pressure_solver == PressureSolverKind::Multigrid)
    multigrid_levels(g, PressureSolverParams{}.coarsest_cells, at + keys.pressure_solver);
  static const char* names[6] = {"x_lo", "x_hi", "y_lo", "y_hi", "z_lo", "z_hi"};
  bool outlet = false;
  double max_in = 0;
  for (int s = 0; s < 6; ++s) {
    const FaceBC& f = p.faces[static_cast<std::size_t>(s)];
    const bool per = g.periodic[s / 2];
    const std::string key = keys.boundaries + "." + names[s];
    if (per != (f.kind == FaceKind::Periodic))
      throw ConfigError(at + key + " = " + to_string(f.kind) + ": the grid axis is " +
                        (per ? "periodic, so the face must be periodic" : "not periodic, so the face must not be periodic"));
    if (f.kind == FaceKind::Outlet) outlet = true;
    if (f.kind == FaceKind::Inlet) {
      if (f.inflow < 0) fail(key + ".velocity", f.inflow, "must be >= 0 (superficial speed into the domain) [m/s]");
      if (f.patch && f.patch_inflow < 0)
        fail(key + ".patch.velocity", f.patch_inflow, "must be >= 0 [m/s]");
      max_in = std::max(max_in, std::max(f.inflow, f.patch ? f.patch_inflow : 0.0));
    }
  }
  if (!outlet)
    throw ConfigError(at + keys.boundaries + ": no face is an outlet; at least one must be (it sets the pressure level)");
  // Explicit upwind convection: |u| dt / h <= 1/2 at the fastest inflow.
  if (max_in * p.dt > 0.5 * g.h)
    fail(keys.dt, p.dt, "too large for the inflow of " + std::to_string(max_in) + " m/s on cells of " +
                         std::to_string(g.h) + " m: need dt <= " + std::to_string(0.5 * g.h / max_in) +
                         " s (Courant number 1/2)");
  const double nu = p.mu / p.rho;
  if (nu * p.dt / (g.h * g.h) > 1.0 / 6.0)
    fail(keys.dt, p.dt, "too large for explicit viscosity: need dt <= " + std::to_string(g.h * g.h / (6 * nu)) + " s");
}

namespace {
PressureSolverParams pressure_params(const GasParams& p) {
  PressureSolverParams q;
  q.kind = p.pressure_solver;
  q.max_iterations = p.cg_max_iterations;
  q.tolerance = p.cg_tolerance;
  q.poll_every = p.cg_poll_every;
  q.graphs = p.pressure_graphs;
  return q;
}
const GasParams& validated(const GasParams& p, const GasGridView& g) {
  validate(p, g);
  return p;
}
}  // namespace

GasSolver::GasSolver(const Exec& ex, const GasGridView& g, const GasParams& p)
    : ex_(ex), g_(g), p_(validated(p, g)), vf_(ex, g, p.deposition), ps_(ex, g, pressure_params(p)) {
  // Zeroed in the order of the gas's queue: on a second queue (lagged forces)
  // the first kernels there (set_velocity) do not wait for memsets on the
  // legacy default stream.
  const Backend b = ex.backend();
  const Index nc = g.cells();
  for (int a = 0; a < 3; ++a) {
    const Index nf = face_count(g, a);
    u_[a] = Buffer<double>(b, nf);
    uh_[a] = Buffer<double>(b, nf);
    af_[a] = Buffer<double>(b, nf);
    u_[a].fill_zero(ex_);
    uh_[a].fill_zero(ex_);
    af_[a].fill_zero(ex_);
    uc_[a] = Buffer<double>(b, nc);
    gradp_[a] = Buffer<double>(b, nc);
    BV_[a] = Buffer<double>(b, nc);
    BV_[a].fill_zero(ex_);
    uc_[a].fill_zero(ex_);
    gradp_[a].fill_zero(ex_);
  }
  eps_ = Buffer<double>(b, nc);
  eps_old_ = Buffer<double>(b, nc);
  eps_.fill_zero(ex_);  // set by initialise(); zeroed so that no copy reads unset bytes before it
  eps_old_.fill_zero(ex_);
  pres_ = Buffer<double>(b, nc);
  pres_.fill_zero(ex_);
  B_ = Buffer<double>(b, nc);
  B_.fill_zero(ex_);
  acc_ = Buffer<unsigned long long>(b, 4 * nc);
  rhs_ = Buffer<double>(b, nc);
}

GasSolver::~GasSolver() = default;

namespace {
GasView make_view(const GasGridView& g, const GasParams& p, Buffer<double>* u, Buffer<double>* uh, Buffer<double>* af,
                  Buffer<double>& eps, Buffer<double>& eps_old, Buffer<double>& pres, Buffer<double>& B,
                  Buffer<double>* BV, Buffer<double>* uc, Buffer<double>* gp) {
  GasView v{};
  v.g = g;
  for (int s = 0; s < 6; ++s) {
    const FaceBC& f = p.faces[static_cast<std::size_t>(s)];
    v.bc[s].kind = static_cast<int>(f.kind);
    v.bc[s].inflow = f.inflow;
    v.bc[s].patch = f.patch;
    v.bc[s].patch_inflow = f.patch_inflow;
    v.bc[s].pressure = f.pressure;
    for (int t = 0; t < 2; ++t) {
      v.bc[s].lo[t] = f.patch_lo[t];
      v.bc[s].hi[t] = f.patch_hi[t];
    }
  }
  for (int a = 0; a < 3; ++a) {
    v.u[a] = u[a].data();
    v.uh[a] = uh[a].data();
    v.af[a] = af[a].data();
    v.BV[a] = BV[a].data();
    v.uc[a] = uc[a].data();
    v.gp[a] = gp[a].data();
    v.grav[a] = p.gravity[a];
  }
  v.eps = eps.data();
  v.eps_old = eps_old.data();
  v.p = pres.data();
  v.B = B.data();
  v.dt = p.dt;
  v.rho = p.rho;
  v.nu = p.mu / p.rho;
  return v;
}
}  // namespace

void GasSolver::initialise(const dem::ParticleView& p) {
  vf_.deposit(p);
  for_each(ex_, g_.cells(), GasFraction{vf_.solid().data(), eps_.data(), p_.min_gas_fraction});
  // A copy on the gas's queue, after GasFraction (a legacy-stream cudaMemcpy
  // would not wait for it on a second queue).
  for_each(ex_, g_.cells(), CopyCells{eps_.data(), eps_old_.data()});
  initialised_ = true;
}

void GasSolver::set_velocity(const Vec3d& u) {
  for (int a = 0; a < 3; ++a) for_each(ex_, u_[a].size(), Fill{u_[a].data(), u[a]});
  GasView v = make_view(g_, p_, u_, uh_, af_, eps_, eps_old_, pres_, B_, BV_, uc_, gradp_);
  for_each(ex_, g_.cells(), CellFields{v});
}

void GasSolver::set_inflow(int face, double inflow) {
  GasParams q = p_;
  if (face < 0 || face > 5 || q.faces[static_cast<std::size_t>(face)].kind != FaceKind::Inlet)
    throw ConfigError("gas: face " + std::to_string(face) + " is not an inlet");
  q.faces[static_cast<std::size_t>(face)].inflow = inflow;
  validate(q, g_);
  p_ = q;
}

void GasSolver::step(const dem::ParticleView& p) {
  if (!initialised_) initialise(p);
  // Phase timing (time_phases): the wall time since the last mark, added to *acc.
  using Clock = std::chrono::steady_clock;
  Clock::time_point t0{};
  if (times_) {
    ex_.synchronize();
    t0 = Clock::now();
  }
  auto mark = [&](double StepTimes::*acc) {
    if (!times_) return;
    ex_.synchronize();
    const Clock::time_point t1 = Clock::now();
    times_->*acc += std::chrono::duration<double>(t1 - t0).count();
    t0 = t1;
  };
  // 1. gas fraction at the particles' new positions.
  eps_.swap(eps_old_);
  vf_.deposit(p);
  for_each(ex_, g_.cells(), GasFraction{vf_.solid().data(), eps_.data(), p_.min_gas_fraction});
  GasView v = make_view(g_, p_, u_, uh_, af_, eps_, eps_old_, pres_, B_, BV_, uc_, gradp_);
  mark(&StepTimes::void_fraction);
  // 2. drag coefficients at the particles, deposited.
  if (gamma_.size() < std::max<Index>(p.n, 1)) {
    // Grown (never in a steady time loop) in the order of the gas's queue:
    // the old buffer freed once that queue's work is done, the new one zeroed
    // there (Buffer::reserve_discard zeroes on the legacy default stream,
    // which a second queue does not wait for).
    ex_.synchronize();
    gamma_ = Buffer<double>(ex_.backend(), std::max<Index>(p.n, 1));
    gamma_.fill_zero(ex_);
  }
  acc_.fill_zero(ex_);
  const DragParams dp{p_.drag, p_.rho, p_.mu};
  for_each(ex_, p.n, DragDeposit{v, p_.deposition, dp, vf_.solid().data(), 1.0 - p_.min_gas_fraction, p,
                                 gamma_.data(), acc_.data()});
  const Index nc = g_.cells();
  for_each(ex_, nc, DragFields{acc_.data(), B_.data(), BV_[0].data(), BV_[1].data(), BV_[2].data(), nc});
  mark(&StepTimes::drag);
  // 3. predictor.
  for_each(ex_, face_count(g_, 0), Predictor<0>{v});
  for_each(ex_, face_count(g_, 1), Predictor<1>{v});
  for_each(ex_, face_count(g_, 2), Predictor<2>{v});
  // 4. pressure.
  for_each(ex_, nc, PressureRhs{v, rhs_.data()});
  const double* af[3] = {af_[0].data(), af_[1].data(), af_[2].data()};
  ps_.solve(af, rhs_.data(), pres_.data());
  // 5. correction, cell fields.
  for_each(ex_, face_count(g_, 0), Correct<0>{v});
  for_each(ex_, face_count(g_, 1), Correct<1>{v});
  for_each(ex_, face_count(g_, 2), Correct<2>{v});
  for_each(ex_, nc, CellFields{v});
  mark(&StepTimes::gas);
  // 6. forces on the particles.
  if (p.ext_force) for_each(ex_, p.n, ParticleForce{v, p_.deposition, p, gamma_.data()});
  mark(&StepTimes::drag);
}

CgReport GasSolver::last_solve() const { return ps_.last_report(); }

namespace {
constexpr std::uint32_t kGasStateTag = 0x47415331;  // "GAS1": the layout of save_state
}

void GasSolver::save_state(ckpt::Sink& out) const {
  ex_.synchronize();
  out.put<std::uint32_t>(kGasStateTag);
  for (int a = 0; a < 3; ++a) out.put<std::int32_t>(g_.n[a]);
  out.put<double>(g_.h);
  out.put<std::uint8_t>(initialised_ ? 1 : 0);
  for (int a = 0; a < 3; ++a) {
    out.put_buffer(u_[a]);
    out.put_buffer(uh_[a]);
    out.put_buffer(af_[a]);
  }
  out.put_buffer(eps_);
  out.put_buffer(eps_old_);
  out.put_buffer(pres_);
  out.put_buffer(B_);
  for (int a = 0; a < 3; ++a) {
    out.put_buffer(uc_[a]);
    out.put_buffer(gradp_[a]);
    out.put_buffer(BV_[a]);
  }
}

void GasSolver::load_state(ckpt::Source& in) {
  ex_.synchronize();  // the copies below are ordered after the legacy default stream only
  in.expect<std::uint32_t>(kGasStateTag, "the gas state's layout tag");
  for (int a = 0; a < 3; ++a) in.expect<std::int32_t>(g_.n[a], "the gas grid's cell count");
  in.expect<double>(g_.h, "the gas cell size");
  const auto init = in.get<std::uint8_t>();
  for (int a = 0; a < 3; ++a) {
    in.get_buffer(u_[a]);
    in.get_buffer(uh_[a]);
    in.get_buffer(af_[a]);
  }
  in.get_buffer(eps_);
  in.get_buffer(eps_old_);
  in.get_buffer(pres_);
  in.get_buffer(B_);
  for (int a = 0; a < 3; ++a) {
    in.get_buffer(uc_[a]);
    in.get_buffer(gradp_[a]);
    in.get_buffer(BV_[a]);
  }
  initialised_ = init != 0;
}

}  // namespace lbdem::cfd
