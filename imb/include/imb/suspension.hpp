#pragma once
// The periodic gas-solid suspension of the first paper (Sec. 2, Table 2) as a
// production run: the statistics a suspension study publishes, computed on the
// device as a few numbers per sample, and its series.csv. Its set-up is
// dem/packing.hpp, the Wen-Yu slip it is compared with cfd/homogeneous_slip.hpp.
// Lattice units throughout (cell size 1, fluid time step 1, fluid density 1).
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/exec.hpp"
#include "dem/system.hpp"
#include "core/checkpoint.hpp"
#include "core/output.hpp"
#include "lbm/solver.hpp"

namespace lbdem::halo {
class Comm;
}

namespace lbdem::imb {

class CoupledSolver;

// ----------------------------------------------------------------- statistics
// What the statistics need to know about the scene (lattice units).
struct SuspensionStatsSpec {
  int dim = 3;
  std::array<long, 3> fluid_lo{0, 0, 0}, fluid_hi{1, 1, 1};  // the fluid box (cells), periodic axes whole
  std::array<bool, 3> periodic{true, true, true};
  std::array<double, 3> gravity{0, 0, 0};
  std::array<double, 3> body_force{0, 0, 0};  // on the fluid, per unit volume
  double fluid_density = 1;
  bool buoyancy = true;            // ext_force holds the buoyancy -rho_f V_p g (imb/coupled.hpp)
  double diameter = 1;             // particle diameter (the filter widths are multiples of it)
  std::vector<double> filter_widths{2, 4, 8};  // in particle diameters
  // A run on several ranks (each holding its own particles): the sums of a
  // sample are over all of them, every rank gets them (collective), and only
  // rank 0 writes series.csv. Null: one rank.
  const halo::Comm* comm = nullptr;
  // Every rank's owned cells (index = rank; global cell indices, the frame of
  // fluid_lo): each rank keeps the coarse cells near its own piece only and
  // owns those whose lowest cell lies in its piece. Empty: one piece.
  std::vector<std::array<long, 3>> piece_offset, piece_cells;
};

// One sample. Velocities in cells per step, forces in lattice units.
struct SuspensionSample {
  double fluid_volume = 0;                    // box volume minus the particles' volume
  std::array<double, 3> fluid_velocity{};     // mean over the fluid volume
  std::array<double, 3> particle_velocity{};  // mean over the particles
  std::array<double, 3> slip{};               // fluid_velocity - particle_velocity
  std::array<double, 3> drag{};               // total hydrodynamic force without buoyancy
  std::array<double, 3> drag_per_particle{};
  double drag_over_weight = 0;                // drag along -g over the particles' net weight (0 without gravity)
  std::array<double, 3> velocity_variance{};  // <(v - <v>)^2> per direction
  double granular_temperature = 0;            // mean of the variances over the dim directions
  std::array<double, 3> particle_momentum{};  // sum m v (held particles excluded)
  // Per filter width: variance of the coarse-grained solid fraction, and the
  // same over its value for independently placed particles (phi V_p / V_bin):
  // 1 for a random suspension, > 1 when the particles cluster.
  std::vector<double> phi_variance, phi_variance_rel;
  std::vector<std::array<long, 3>> bins;      // coarse cells per axis of each width
};

// Device reductions over particles (and the fluid's diagnostics, computed by
// the caller every sample anyway): nothing is downloaded but a few numbers.
// Allocates its buffers once, at construction.
class SuspensionStatistics {
 public:
  SuspensionStatistics(const Exec& ex, const SuspensionStatsSpec& spec);
  ~SuspensionStatistics();
  SuspensionStatistics(const SuspensionStatistics&) = delete;
  SuspensionStatistics& operator=(const SuspensionStatistics&) = delete;
  // The fluid diagnostics `d` of the same state (LbmSolver::diagnostics()).
  SuspensionSample sample(dem::DemSystem& dem, const lbm::LbmDiagnostics& d);
  // series.csv column names of a sample (the order of row()).
  std::vector<std::string> columns() const;
  std::vector<double> row(const SuspensionSample& s) const;
  const SuspensionStatsSpec& spec() const { return spec_; }
  // Coarse cells this rank holds (all widths): those within a particle
  // diameter of its piece, rounded out to whole coarse cells.
  Index bins_held() const;

 private:
  struct Impl;
  SuspensionStatsSpec spec_;
  std::unique_ptr<Impl> impl_;
};

// ----------------------------------------------------------------- references
// Net weight (m - rho_f V_p) |g| of the mean particle of `p` (a disk's in 2D,
// or with `sphere` that of a sphere of the same diameter and density), 0
// without gravity; held particles (mass > 1e100) count 0.
double mean_net_weight(const SuspensionStatsSpec& spec, const dem::HostParticles& p, bool sphere = false);
// One free sphere in a fully periodic cube of side L (`cells`), its weight
// balanced: in its own frame the flow through a simple cubic array of
// spheres. Stokes drag of that array (Sangani & Acrivos 1982, Eq. 60):
// F = 3 pi mu d U K(d/L), F the force that balances a mean pressure gradient
// over the whole period, W / (1 - phi) for the weight W that the fluid's body
// force balances over the fluid volume, and U the superficial velocity,
// (1 - phi) times the slip. So the terminal slip is
// W / ((1 - phi)^2 3 pi mu d K). 0 where the scene is not of that kind
// (accurate for Re_p << 1; the Oseen correction is 3/16 Re_p).
double periodic_settling_reference(const SuspensionStatsSpec& spec, const dem::HostParticles& p,
                                   const std::array<long, 3>& cells, double tau, double solid_fraction);
// The sample's slip along -g (along y without gravity).
double slip_along_gravity(const SuspensionStatsSpec& spec, const SuspensionSample& s);

// ----------------------------------------------------------------- series.csv
// The particle scene's time series, one row per call (lattice units; the
// run's summary.json gives dx, dt and dm to convert): step, time (seconds in
// a physical-unit scene, steps in a lattice-unit one), the fluid's relative
// mass change, momentum and largest Mach number, the suspension statistics
// (SuspensionStatistics::columns()), and for scenes of at most kTrackedMax
// particles the state of particle id 0 (x0 ... tz0; a download of those few
// particles). Times itself: seconds() is the wall time spent in append().
class ParticleSeries {
 public:
  static constexpr long kTrackedMax = 16;
  // With `run` restarting, the rows up to its checkpoint are kept (a series
  // of `interval` steps) and the file goes on from there.
  // `diagnostics`: the fluid's diagnostics over all ranks (a run on several
  // ranks; default: cs.fluid().diagnostics()).
  ParticleSeries(const std::string& path, CoupledSolver& cs, const SuspensionStatsSpec& spec, double dt,
                 const ckpt::Run* run = nullptr, long interval = 1,
                 std::function<lbm::LbmDiagnostics()> diagnostics = {});
  // What a checkpoint keeps of the series: the reference mass (the averages
  // are taken again from the rows a restart keeps); restore() takes it back.
  std::vector<double> state() const { return {d0_.mass}; }
  void restore(const std::vector<double>& v);
  // Appends the row of `step`; returns the fluid diagnostics it used, for the
  // caller's divergence checks.
  lbm::LbmDiagnostics append(long step);
  // Samples at steps >= `step` enter the averages below (the rows a restart
  // kept included).
  void average_from(long step);
  double mean_slip() const { return samples_ > 0 ? slip_sum_ / double(samples_) : 0.0; }  // along -g (y without gravity)
  double mean_drag_over_weight() const { return samples_ > 0 ? drag_sum_ / double(samples_) : 0.0; }
  long averaged_samples() const { return samples_; }
  const SuspensionSample& last() const { return last_; }
  double seconds() const { return seconds_; }

 private:
  CoupledSolver& cs_;
  std::function<lbm::LbmDiagnostics()> diagnostics_;
  SuspensionStatistics stats_;
  std::vector<std::string> columns_;
  std::vector<std::vector<double>> kept_;  // rows a restart kept, until average_from() has taken them
  io::TimeSeries out_;
  double dt_;
  bool track_;
  bool have_d0_ = false;
  lbm::LbmDiagnostics d0_;
  SuspensionSample last_;
  long average_from_ = 0, samples_ = 0;
  double slip_sum_ = 0, drag_sum_ = 0, seconds_ = 0;
  std::array<double, 3> along_{0, 1, 0};  // unit vector along -g
};

}  // namespace lbdem::imb
