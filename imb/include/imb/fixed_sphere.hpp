#pragma once
// Flow through a simple cubic (3D) or square (2D) array of fixed spheres /
// disks, resolved with partially saturated cells: the validation scene of the
// first paper (Table 1) and our drag reference. Used by the `fixed_sphere`
// scene, the tests and the speed-vs-error benchmark.
#include <string>

#include "lbm/distributed_fluid.hpp"
#include "core/config.hpp"
#include "core/exec.hpp"
#include "imb/fraction_table.hpp"
#include "imb/psm.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/solid_fraction.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// Sangani & Acrivos (1982, Int. J. Multiphase Flow 8, 193), Eq. 60: the drag
// coefficient K = F / (6 pi mu a U) of a simple cubic array, chi = d/L <= 0.75.
double sangani_acrivos_K(double chi);
// Zick & Homsy (1982, J. Fluid Mech. 115, 13), Table 2: the drag coefficient
// K of a simple cubic array at the volume fractions phi = pi/6 chi^3 they
// tabulate, in the normalisation of Sangani & Acrivos (F = 6 pi mu a K U, U
// the mean velocity over the whole period): phi 0.027, 0.064, 0.125, 0.216,
// 0.343, 0.45, 0.5236 (chi = 1, touching spheres). The dense ones, past the
// series' chi 0.75, are the reference there.
struct ZickHomsyPoint {
  double phi, K;
};
inline constexpr ZickHomsyPoint kZickHomsy[7] = {{0.027, 2.008}, {0.064, 2.810}, {0.125, 4.292}, {0.216, 7.442},
                                                 {0.343, 15.4},  {0.45, 28.1},   {0.5236, 42.1}};
// chi = d/L of a tabulated phi: (6 phi / pi)^(1/3).
double zick_homsy_chi(double phi);
// K of the tabulated point whose chi is within kZickHomsyChiTolerance of chi;
// NaN between the points (the table is not interpolated). The tolerance moves
// K by at most ~0.15 % at phi 0.343 (d ln K / d ln chi ~ 6 there), below the
// rounding of the tabulated K (3 significant figures: +-0.33 %).
inline constexpr double kZickHomsyChiTolerance = 2e-4;
double zick_homsy_K(double chi);
// The reference K of a simple cubic array at chi = d/L: Sangani & Acrivos for
// chi <= 0.75, Zick & Homsy's tabulated points above (NaN elsewhere); `name`
// receives which.
double sphere_array_K(double chi, const char** name = nullptr);

// Square array of cylinders, Sangani & Acrivos (1982, Int. J. Multiphase Flow
// 8, 193), dilute expansion: F / (4 pi mu U) = 1 / (-ln(c)/2 - 0.738 + c -
// 0.887 c^2 + 2.038 c^3), c the area fraction (accurate to ~1e-3 for c <= 0.2).
double sangani_acrivos_cylinders(double c);

struct FixedSphereSpec {
  int dim = 3;               // 3: sphere (D3Q19); 2: disk (D2Q9)
  double diameter = 10;      // d / l (lattice units)
  double chi = 0.5;          // d / L (L the array period): (0, 0.75], or a dense point of Zick & Homsy
                             // (0.8685, 0.9508, 1; d / L must match it, L = round(d / chi))
  double re_p = 0.2;         // target particle Reynolds number U d / nu (sets the body force)
  double tau = 0.52;         // defaults: the accurate setting (bench/imb/NOTES.md, host study)
  lbm::CollisionKind collision = lbm::CollisionKind::TRT;
  double magic = 1e-4;       // TRT Lambda (BGK: (tau - 1/2)^2)
  lbm::Precision precision = lbm::Precision::FP64;
  lbm::StreamKind streaming = lbm::StreamKind::AA;
  imb::FractionMethod method = imb::FractionMethod::Exact;
  imb::PsmVariant variant = imb::PsmVariant::NEBB;
  imb::PsmWeight weight = imb::PsmWeight::NobleTorczynski;
  double even_relaxation = 0;    // NEBB's solid term relaxes the even part (PsmOptions::even_relaxation)
  const imb::FractionTable* table = nullptr;  // for FractionMethod::Table
  int slots = 4;
  // Auto runs the mapped pipeline here (a fixed sphere is mapped once); Fused on request.
  imb::PsmPipeline pipeline = imb::PsmPipeline::Auto;
  double tolerance = 1e-5;   // steady state: estimated remaining relative change of the drag
  long max_steps = 2000000;
  long check_every = 0;      // 0: about L^2 / (40 nu) steps
  // Periods of the array simulated per axis (each holding the sphere at the
  // same place). 0: one, or two where the sphere leaves less than the cell
  // map needs (floor(d) + 2 > L, imb/cell_slots.hpp); the drag is per sphere.
  int periods = 0;
  double offset = 0.5;       // sphere centre offset from L/2 (cells, all axes). Cell centres sit at
                             // i + 1/2: for even L (chi = 0.5, integer d) L/2 is a cell corner and
                             // 0.5 a cell centre; for odd L the reverse
  // Initial fluid state: at rest, or the Stokes estimate (u = U0 (1 - eps) along
  // the drive, U0 such that the superficial velocity is the reference's
  // U = Re_p nu / d), which starts the slow mean-flow mode near its end value.
  enum class Start { Rest, Estimate };
  Start start = Start::Estimate;
  bool quiet = true;         // progress lines on stderr
  // Ranks: null (or one rank) runs the whole grid; several cut it (`parallel`
  // section: decomposition, transport) and every rank returns the same result.
  const halo::Comm* comm = nullptr;
  halo::ParallelOptions parallel;
  // The names its refusals give dim, diameter, chi and periods: the keys a
  // scene read them from, as written (the scene: geometry.chi); by default
  // these fields'.
  struct Keys {
    std::string dim = "fixed_sphere.dim", diameter = "fixed_sphere.diameter", chi = "fixed_sphere.chi",
                periods = "fixed_sphere.periods";
  } keys;
};

struct FixedSphereResult {
  double K = 0, K_ref = 0, rel_error = 0;  // drag coefficient, reference, (K - K_ref)/K_ref
  const char* reference = "";  // which reference K_ref is (sphere_array_K)
  double force = 0;          // drag per sphere (lattice units), as the array theory defines it
  double exchange = 0;       // momentum exchange measured on the particle
  double balance = 0;        // force the fluid received from the body force (steady: = exchange)
  double mean_u = 0;         // superficial velocity (solid included, lattice units)
  double mean_flux = 0;      // mean momentum density over every cell (diagnostic)
  double fluid_rho = 0;      // mean density of the fluid: sum (1 - eps) rho / sum (1 - eps)
  double mean_rho = 0;       // mean density over every cell (solid included; conserved)
  double re_p = 0;
  double body_force = 0;
  long steps = 0;
  bool converged = false;
  bool interrupted = false;  // stopped by SIGINT/SIGTERM (core/signals.hpp) after `steps` steps
  double remaining = 0;      // estimated remaining relative change of the drag when it stopped
  double seconds = 0;        // wall time of the time loop
  double mlups = 0;          // cell updates per second / 1e6
  long cells = 0;            // cells simulated: one period, or 2^dim periods when the sphere nearly fills one
};

FixedSphereResult run_fixed_sphere(const FixedSphereSpec& spec, Backend backend);

// The fixed_sphere scene while its case is parsed: the period L = d / chi
// (geometry.diameter, geometry.chi) holds a resolved sphere (L >= 4), the
// grid fits `backend`'s memory, and the plan of `max_steps` steps (`force`:
// --force; `steps_key` names the step count).
void check_fixed_sphere(const Config& root, int dim, double diameter, double chi, lbm::Precision precision,
                        lbm::StreamKind streaming, long max_steps, Backend backend, bool force,
                        const std::string& steps_key);

}  // namespace lbdem::imb
