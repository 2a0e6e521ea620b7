// series.csv of the particle scene (imb/suspension.hpp, ParticleSeries).
#include <chrono>
#include <cmath>

#include "imb/suspension.hpp"
#include "halo/comm.hpp"
#include "imb/coupled.hpp"
#include "imb/fixed_sphere.hpp"

namespace lbdem::imb {

namespace {
std::vector<std::string> series_columns(const SuspensionStatistics& s, bool track) {
  std::vector<std::string> c = {"step", "time", "fluid_mass_rel_change", "fluid_momentum_x", "fluid_momentum_y",
                                "fluid_momentum_z", "max_mach"};
  const auto st = s.columns();
  c.insert(c.end(), st.begin(), st.end());
  if (track)
    for (const char* k : {"x0", "y0", "z0", "vx0", "vy0", "vz0", "wx0", "wy0", "wz0", "fx0", "fy0", "fz0", "tx0",
                          "ty0", "tz0"})
      c.emplace_back(k);
  return c;
}
}  // namespace

ParticleSeries::ParticleSeries(const std::string& path, CoupledSolver& cs, const SuspensionStatsSpec& spec,
                               double dt, const ckpt::Run* run, long interval,
                               std::function<lbm::LbmDiagnostics()> diagnostics)
    : cs_(cs),
      diagnostics_(std::move(diagnostics)),
      stats_(Exec(cs.dem().backend()), spec),
      columns_(series_columns(stats_, cs.dem().global_size() <= kTrackedMax)),
      kept_(run ? run->kept_rows(path, columns_, interval) : std::vector<std::vector<double>>{}),
      out_(spec.comm && !spec.comm->root() ? io::TimeSeries() : io::TimeSeries(path, columns_)),
      dt_(dt),
      track_(cs.dem().global_size() <= kTrackedMax) {
  for (const auto& row : kept_) out_.append(row);
  const auto& g = spec.gravity;
  const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (gn > 0) along_ = {-g[0] / gn, -g[1] / gn, -g[2] / gn};
}

void ParticleSeries::restore(const std::vector<double>& v) {
  if (v.empty()) return;
  d0_.mass = v[0];
  have_d0_ = true;
}

void ParticleSeries::average_from(long step) {
  average_from_ = step;
  // The rows a restart kept enter the averages as if sampled in this job.
  std::size_t is = columns_.size(), id = columns_.size();
  for (std::size_t k = 0; k < columns_.size(); ++k) {
    if (columns_[k] == "slip_x") is = k;
    if (columns_[k] == "drag_over_weight") id = k;
  }
  for (const auto& row : kept_) {
    if (row.empty() || row[0] < double(step) || is + 2 >= row.size() || id >= row.size()) continue;
    slip_sum_ += row[is] * along_[0] + row[is + 1] * along_[1] + row[is + 2] * along_[2];
    drag_sum_ += row[id];
    ++samples_;
  }
  kept_.clear();
}

lbm::LbmDiagnostics ParticleSeries::append(long step) {
  using clk = std::chrono::steady_clock;
  const auto t0 = clk::now();
  const lbm::LbmDiagnostics d = diagnostics_ ? diagnostics_() : cs_.fluid().diagnostics();
  if (!have_d0_) {
    d0_ = d;
    have_d0_ = true;
  }
  last_ = stats_.sample(cs_.dem(), d);
  std::vector<double> row = {double(step), double(step) * dt_, (d.mass - d0_.mass) / d0_.mass, d.momentum[0],
                             d.momentum[1], d.momentum[2], d.max_speed * std::sqrt(3.0)};
  const auto st = stats_.row(last_);
  row.insert(row.end(), st.begin(), st.end());
  if (track_) {
    const auto hp = cs_.dem().download();
    const auto hf = cs_.hydro_force_host();
    const auto ht = cs_.hydro_torque_host();
    std::size_t i0 = 0;
    bool mine = false;
    for (std::size_t i = 0; i < hp.id.size(); ++i)
      if (hp.id[i] == 0) {
        i0 = i;
        mine = true;
      }
    const halo::Comm* comm = stats_.spec().comm;
    if (comm && comm->distributed()) {
      // The owner of particle 0 fills its values, the other ranks zeros: the
      // sum over ranks hands every rank the owner's values unchanged.
      std::vector<double> t(15, 0.0);
      if (mine) {
        std::size_t k = 0;
        for (const Vec3d* v : {&hp.x[i0], &hp.v[i0], &hp.w[i0]})
          for (int a = 0; a < 3; ++a) t[k++] = (*v)[a];
        for (const auto* h : {&hf, &ht})
          for (std::size_t a = 0; a < 3; ++a) t[k++] = (*h)[3 * i0 + a];
      }
      comm->sum(t);
      row.insert(row.end(), t.begin(), t.end());
    } else {
      for (const Vec3d* v : {&hp.x[i0], &hp.v[i0], &hp.w[i0]})
        for (int k = 0; k < 3; ++k) row.push_back((*v)[k]);
      for (const auto* h : {&hf, &ht})
        for (std::size_t k = 0; k < 3; ++k) row.push_back((*h)[3 * i0 + k]);
    }
  }
  if (out_.is_open()) out_.append(row);
  if (step >= average_from_) {
    slip_sum_ += last_.slip[0] * along_[0] + last_.slip[1] * along_[1] + last_.slip[2] * along_[2];
    drag_sum_ += last_.drag_over_weight;
    ++samples_;
  }
  seconds_ += std::chrono::duration<double>(clk::now() - t0).count();
  return d;
}

// ----------------------------------------------------------------- references
double mean_net_weight(const SuspensionStatsSpec& spec, const dem::HostParticles& p, bool sphere) {
  const auto& g = spec.gravity;
  const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  double w = 0;
  for (std::size_t i = 0; i < p.r.size(); ++i) {
    const double r = p.r[i], vs = 4.0 / 3.0 * M_PI * r * r * r;
    const double own = spec.dim == 3 ? vs : M_PI * r * r;  // the particle's volume (a disk's area in 2D)
    const double v = sphere ? vs : own;
    if (p.mass[i] > 1e100) continue;  // held
    w += (p.mass[i] / own - spec.fluid_density) * v * gn;
  }
  return p.r.empty() ? 0.0 : w / double(p.r.size());
}

double periodic_settling_reference(const SuspensionStatsSpec& spec, const dem::HostParticles& p,
                                   const std::array<long, 3>& n, double tau, double solid_fraction) {
  const auto& per = spec.periodic;
  if (spec.dim != 3 || p.size() != 1 || !(per[0] && per[1] && per[2]) || n[0] != n[1] || n[1] != n[2]) return 0;
  if (p.mass[0] > 1e100) return 0;
  const double chi = spec.diameter / double(n[0]);
  const double W = mean_net_weight(spec, p);
  if (!(chi <= 0.75) || !(W > 0)) return 0;
  const double mu = spec.fluid_density * (tau - 0.5) / 3.0;
  const double phi = solid_fraction;
  return W / ((1 - phi) * (1 - phi) * 3 * M_PI * mu * spec.diameter * sangani_acrivos_K(chi));
}

double slip_along_gravity(const SuspensionStatsSpec& spec, const SuspensionSample& s) {
  const auto& g = spec.gravity;
  const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (!(gn > 0)) return s.slip[1];
  return -(s.slip[0] * g[0] + s.slip[1] * g[1] + s.slip[2] * g[2]) / gn;
}

}  // namespace lbdem::imb
