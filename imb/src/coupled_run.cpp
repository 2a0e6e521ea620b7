// Around the coupled step of a run (imb/coupled_run.hpp).
#include "imb/coupled_run.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/phase_clock.hpp"
#include "halo/decomposition.hpp"

namespace lbdem::imb {

dem::DemDomain coupled_domain(const std::string& source, const lbm::LbmSetup& fluid, int dim, const dem::DemParams& dp,
                               const std::vector<double>& radii, const halo::ParallelOptions& parallel,
                               const halo::Comm& comm, const CoupledKeys& keys) {
  const halo::Decomposition dec =
      halo::decompose(fluid.domain, comm.size(), parallel.decomposition, "parallel.decomposition");
  dem::DemDomain dom = dem::domain_from_decomposition(comm, dec, dp);
  dom.transport = parallel.transport;
  const double w = dem::ghost_width(dp, radii);
  double r_max = 0;
  for (double r : radii) r_max = std::max(r_max, r);
  const double skin = dp.skin > 0 ? dp.skin : w - 2 * r_max;
  const double reach = 0.1 * r_max + std::sqrt(double(dim)) / 2 + 1;
  if (r_max + skin / 2 < reach)
    throw ConfigError(source + ": particles.diameter = " + std::to_string(2 * r_max) +
                      " cells is too small to run on several ranks: a particle's ghost copies (kept within 2 r + "
                      "skin of a piece) would not reach every cell its solid fraction covers on a neighbouring "
                      "piece; use a diameter of at least " + std::to_string(2 * (reach - skin / 2) + 0.01) +
                      " cells, or one rank");
  for (int a = 0; a < 3; ++a) {
    const auto& cut = dom.cuts[static_cast<std::size_t>(a)];
    for (std::size_t i = 0; dec.dims[static_cast<std::size_t>(a)] > 1 && i + 1 < cut.size(); ++i)
      if (cut[i + 1] - cut[i] < w)
        throw ConfigError(source + ": parallel.decomposition = " + dec.describe() + " cuts axis " +
                          std::string(1, char('x' + a)) + " into a piece of " + std::to_string(cut[i + 1] - cut[i]) +
                          " cells, thinner than the particles' ghost width 2 r + skin = " + std::to_string(w) +
                          " cells (a particle's contact partners and its cells must lie in the neighbouring pieces): "
                          "use fewer ranks along " + std::string(1, char('x' + a)) + " or a larger " + keys.cells);
  }
  return dom;
}

void timing_json(json::Value& js, CoupledSolver& cs, lbm::DistributedFluid& dfluid, const halo::Comm& comm,
                 const std::array<double, 4>& setup, double loop_secs, double output_secs, long snapshots,
                 double ppr_max, double ppr_mean, long ppr_step) {
  PhaseClock& clock = cs.phase_clock();
  clock.collect();
  std::vector<double> t = clock.totals();
  std::vector<std::string> names = clock.names();
  const lbm::FluidHalo* h = dfluid.halo();
  t.push_back(h ? h->times().start + h->times().finish : 0.0);
  names.push_back("exposed_communication");
  for (double v : setup) t.push_back(v);
  for (const char* n : {"packing", "particle_distribution", "fluid_initial_state", "first_map"}) names.push_back(n);
  t.push_back(output_secs);
  names.push_back("output");
  // This rank's phases together and its loop time (the phases lie inside the loop).
  double phase_sum = 0;
  for (double v : clock.totals()) phase_sum += v;
  t.push_back(phase_sum);
  names.push_back("phase_sum");
  t.push_back(loop_secs);
  names.push_back("loop");
  std::vector<double> mx = t, mean = t;
  if (comm.distributed()) {
    for (double& v : mx) v = comm.max(v);
    comm.sum(mean);
    for (double& v : mean) v /= comm.size();
  }
  const std::size_t nphase = clock.names().size() + 1;
  auto pair = [&](std::size_t i) { return json::Value::object().set("max", mx[i]).set("mean", mean[i]); };
  json::Value& tj = js["timing"];
  for (std::size_t i = 0; i < nphase; ++i) tj["phases"].set(names[i], pair(i));
  double setup_max = 0;
  for (std::size_t i = nphase; i < nphase + 4; ++i) {
    tj["setup"].set(names[i], pair(i));
    setup_max += mx[i];
  }
  tj.set("setup_seconds", setup_max)
      .set("loop_seconds", mx[nphase + 6])
      .set("phase_sum_seconds", mx[nphase + 5])
      .set("output_seconds", pair(nphase + 4))
      .set("snapshots", snapshots)
      .set("output_fraction_of_run", mx[nphase + 4] / std::max(mx[nphase + 6], 1e-12))
      .set("steps_timed", clock.steps())
      .set("note",
           "seconds per rank summed over the run, max and mean over the ranks; phases of the coupled step: fluid_psm "
           "(fluid + PSM step, halo exchange included), force_reduction (ghost forces to their owners), dem (the DEM "
           "sub-steps, migration and ghost rebuilds included), ghost_sync (ghost velocities), map (particles to "
           "cells); exposed_communication is the part of fluid_psm waiting for the halo; on the device the phases are "
           "sampled every 16th step with events; setup_seconds sums the set-up phases' maxima; "
           "output_fraction_of_run: the snapshots' wall time over loop_seconds (which includes those inside the "
           "loop); loop_seconds and phase_sum_seconds (the phases of a rank together): max over the ranks");
  js["particles_per_rank"]
      .set("max", ppr_max)
      .set("mean", ppr_mean)
      .set("imbalance", ppr_mean > 0 ? ppr_max / ppr_mean : 0.0)
      .set("step", ppr_step)
      .set("note", "owned particles per rank at the series row with the largest max / mean");
}

}  // namespace lbdem::imb
