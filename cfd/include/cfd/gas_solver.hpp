#pragma once
// The gas phase of the unresolved mode: the volume-averaged incompressible
// equations of Anderson & Jackson, set I ("model A", as Yu et al. 2024
// Eq. 1-4: the gas carries -eps grad p, each particle feels -V_p grad p plus
// the drag), on a coarse staggered (MAC) grid, finite volumes, everything in
// single-source kernels (core/exec.hpp) so it runs on the GPU or the host.
//
//   d(eps)/dt + div(eps u) = 0                                  (rho_g constant)
//   rho eps (du/dt + u.grad u) = -eps grad p + mu eps lap u + eps rho g + beta (v_s - u)
//
// with beta = sum_i gamma_i w_i / V_c and beta v_s = sum_i gamma_i v_i w_i / V_c
// over the particles (gamma_i from cfd/drag.hpp, w_i the void-fraction
// weights). One step (dt):
//  1. eps^{n+1} from the particles' new positions (cfd/void_fraction.hpp);
//  2. gamma_i at the particles from the gas velocity and solid fraction
//     interpolated with the same weights, deposited as beta and beta v_s;
//  3. predictor on every face: first-order upwind convection, explicit
//     viscosity and gravity, drag implicit in u (point-implicit: the face's
//     own beta), u^ = (u + dt(-u.grad u + nu lap u + g) + dt beta v_s / (eps rho))
//     / (1 + dt beta / (eps rho));
//  4. pressure: div(eps c grad p) = div(eps u^) + (eps^{n+1} - eps^n) / dt with
//     c = dt / (rho (1 + dt beta / (eps rho))), solved by conjugate gradients
//     preconditioned by the diagonal or by a multigrid V-cycle
//     (cfd/pressure_solver.hpp) with all scalars on the device;
//  5. correction u = u^ - c grad p, so that the discrete continuity equation
//     holds to the solver tolerance in every cell;
//  6. the force on each particle, gamma_i (u - v_i) - V_p grad p, into the
//     DEM's coupling input (ParticleView::ext_force).
// Boundaries per box face: periodic, no-slip or free-slip wall, inlet (a
// uniform superficial velocity into the domain plus an optional rectangular
// patch at another velocity: distributor and spout), pressure outlet.
#include <array>
#include <string>

#include "cfd/drag.hpp"
#include "cfd/gas_grid.hpp"
#include "cfd/pressure_solver.hpp"
#include "cfd/void_fraction.hpp"
#include "core/buffer.hpp"
#include "core/vec.hpp"
#include "dem/particle_view.hpp"

namespace lbdem::ckpt {
class Sink;
class Source;
}

namespace lbdem::cfd {

enum class FaceKind { Periodic, NoSlipWall, FreeSlipWall, Inlet, Outlet };

const char* to_string(FaceKind k);
FaceKind parse_face_kind(const std::string& key, const std::string& value);

// One face of the box. Faces are numbered 2 axis + side: x-, x+, y-, y+, z-, z+.
struct FaceBC {
  FaceKind kind = FaceKind::NoSlipWall;
  double inflow = 0;       // inlet: superficial velocity into the domain [m/s]
  bool patch = false;      // inlet: a rectangle with its own velocity (a spout)
  double patch_lo[2] = {0, 0}, patch_hi[2] = {0, 0};  // [m], along the face's two other axes in x, y, z order
  double patch_inflow = 0;  // [m/s]
  double pressure = 0;      // outlet: gauge pressure [Pa]
};

struct GasParams {
  double rho = 1.2;    // [kg/m^3]
  double mu = 1.8e-5;  // [Pa s]
  Vec3d gravity{0, 0, -9.80665};
  double dt = 1e-4;  // gas time step [s]
  std::array<FaceBC, 6> faces{};
  DragLaw drag = DragLaw::Gidaspow;
  Deposition deposition = Deposition::Centroid;
  // Gas fraction floor used by the gas equations and the drag (a centroid
  // deposition can put more solid into a cell than fits).
  double min_gas_fraction = 0.2;
  // The pressure solve (cfd/pressure_solver.hpp): Jacobi- or multigrid-
  // preconditioned CG, both to the same tolerance on the diagonally scaled
  // residual.
  PressureSolverKind pressure_solver = PressureSolverKind::Cg;
  int cg_max_iterations = 2000;
  double cg_tolerance = 1e-10;  // on sqrt(r^T D^-1 r / b^T D^-1 b)
  // How often (iterations) the host asks the device whether CG has converged
  // (one small copy each; multigrid asks first at the last solve's count;
  // multigrid on the GPU with the graphs never asks: it repeats this many
  // iterations on the device until converged, PressureSolverParams::device_loop);
  // iterations after convergence are skipped on the device either way.
  int cg_poll_every = 25;
  // Multigrid on the GPU: the iterations between two polls as one CUDA graph.
  bool pressure_graphs = true;
};

// The names validate() gives the parameters: the keys a reader set them from,
// as written (cfd::read_gas: gas.density, gas.pressure_solver.tolerance); by
// default the fields' names under "gas".
struct GasKeys {
  std::string rho = "gas.rho", mu = "gas.mu", dt = "gas.dt", min_gas_fraction = "gas.min_gas_fraction";
  std::string cg_max_iterations = "gas.cg_max_iterations", cg_tolerance = "gas.cg_tolerance",
              cg_poll_every = "gas.cg_poll_every", pressure_solver = "gas.pressure_solver";
  std::string boundaries = "gas.boundaries";  // its faces: boundaries.x_lo, ...
};

// Refuses inconsistent parameters with ConfigError naming the key (`keys`),
// the value and what is valid; the message starts with "where: " when `where`
// (the case file) is given.
void validate(const GasParams& p, const GasGridView& g, const GasKeys& keys = {}, const std::string& where = "");

// Wall time of the phases of step() [s], accumulated when a solver is asked
// to time them (benchmarks): the void fraction (deposition and gas
// fraction), the drag (coefficients at the particles, their deposition, the
// forces on the particles) and the gas (predictor, pressure, correction).
struct StepTimes {
  double void_fraction = 0, drag = 0, gas = 0;
};

class GasSolver {
 public:
  GasSolver(const Exec& ex, const GasGridView& g, const GasParams& p);
  ~GasSolver();
  GasSolver(const GasSolver&) = delete;
  GasSolver& operator=(const GasSolver&) = delete;

  // Gas fraction from the particles at their current positions, taken as the
  // previous one too (no spurious d eps/dt at the first step). step() calls
  // it on its first call if nobody did.
  void initialise(const dem::ParticleView& p);
  // One gas step with the particles where they are now; writes the particle
  // forces into p.ext_force when that is not null.
  void step(const dem::ParticleView& p);

  // Uniform initial gas velocity (interstitial) on every face (boundary faces
  // take their prescribed values again at the next step).
  void set_velocity(const Vec3d& u);
  // Changes an inlet's superficial velocity (face 0..5 = x-, x+, y-, y+,
  // z-, z+) for the following steps; checked like the case file's value.
  void set_inflow(int face, double inflow);

  const GasGridView& grid() const { return g_; }
  const GasParams& params() const { return p_; }
  // Face velocities along axis a: (n_a + 1) faces x the other two extents,
  // face i being the lower face of cell i (x-fastest over the face box).
  const Buffer<double>& face_velocity(int a) const { return u_[a]; }
  const Buffer<double>& gas_fraction() const { return eps_; }
  const Buffer<double>& gas_fraction_old() const { return eps_old_; }
  const Buffer<double>& pressure() const { return pres_; }
  const Buffer<double>& cell_velocity(int a) const { return uc_[a]; }
  const Buffer<double>& drag_gamma() const { return gamma_; }  // per particle [kg/s]
  const VoidFraction& void_fraction() const { return vf_; }
  const PressureSolver& pressure_solver() const { return ps_; }
  // Synchronises and reads the last pressure solve's report.
  CgReport last_solve() const;
  // With t set, step() waits for the device at the end of each phase and adds
  // the phases' wall times to *t (the waits cost time of their own: for a
  // split, not for the whole step's speed); nullptr stops it.
  void time_phases(StepTimes* t) { times_ = t; }

  // Checkpoint (core/checkpoint.hpp): every field a later step reads (face
  // velocities, gas fraction, pressure as the solve's initial guess, cell
  // velocities, which the drag reads before the step recomputes them) and
  // the fields the last step left (predictor, coefficients, drag fields,
  // pressure gradient), bit for bit. load_state() checks the grid and the
  // face counts against this solver's and leaves it initialised.
  void save_state(ckpt::Sink& out) const;
  void load_state(ckpt::Source& in);

 private:

  Exec ex_;
  GasGridView g_;
  GasParams p_;
  VoidFraction vf_;
  bool initialised_ = false;
  Buffer<double> u_[3], uh_[3], af_[3];
  Buffer<double> eps_, eps_old_, pres_, uc_[3], gradp_[3], B_, BV_[3];
  Buffer<unsigned long long> acc_;  // B and BV in fixed point, 4 x cells
  Buffer<double> gamma_;
  Buffer<double> rhs_;
  PressureSolver ps_;
  StepTimes* times_ = nullptr;
};

}  // namespace lbdem::cfd
