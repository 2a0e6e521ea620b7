#include "imb/coupled.hpp"

#include <cmath>
#include <map>
#include <sstream>
#include <string>

#include "core/buffer.hpp"
#include "core/error.hpp"
#include "imb/solid_fraction.hpp"

namespace lbdem::imb {

namespace {
double particle_volume(double r, int dim) {
  return dim == 3 ? 4.0 / 3.0 * M_PI * r * r * r : M_PI * r * r;
}
}  // namespace

double psm_weight_sum(double r, int dim, double tau, PsmWeight weight) {
  if (!(r > 0)) return 0.0;
  const double tm = psm_weight_t(tau, weight);
  const int lo = -static_cast<int>(std::ceil(r)) - 1, hi = static_cast<int>(std::ceil(r)) + 1;
  double total = 0;
  int samples = 0;
  for (int s = 0; s < (dim == 3 ? 8 : 4); ++s) {
    // Centre offsets 1/4, 3/4 of a cell on each axis: the average over positions.
    const double o[3] = {0.25 + 0.5 * (s & 1), 0.25 + 0.5 * ((s >> 1) & 1), dim == 3 ? 0.25 + 0.5 * ((s >> 2) & 1) : 0.0};
    double sum = 0;
    for (int k = dim == 3 ? lo : 0; k <= (dim == 3 ? hi : 0); ++k)
      for (int j = lo; j <= hi; ++j)
        for (int i = lo; i <= hi; ++i) {
          const double rx = i + 0.5 - o[0], ry = j + 0.5 - o[1], rz = k + 0.5 - o[2];
          const double e = dim == 3 ? exact_fraction_3d(rx, ry, rz, r) : exact_fraction_2d(rx, ry, r);
          if (e <= 0) continue;
          sum += psm_weight(e, tm, weight);
        }
    total += sum;
    ++samples;
  }
  return total / samples;
}

double psm_fluid_weight(const dem::HostParticles& p, int dim, double total_volume, double tau, PsmWeight weight) {
  if (!(tau > 0.5)) throw ConfigError("fluid.tau = " + std::to_string(tau) + ": must be > 1/2");
  double solid_weight = 0;
  std::map<double, double> weight_of_radius;  // S_B per distinct radius (monodisperse: one evaluation)
  for (Index i = 0; i < p.size(); ++i) {
    const double r = p.r[static_cast<std::size_t>(i)];
    auto it = weight_of_radius.find(r);
    if (it == weight_of_radius.end()) {
      if (weight_of_radius.size() >= 64) {  // strongly polydisperse: S_B/V_p of the nearest radius computed
        auto near = weight_of_radius.lower_bound(r);
        if (near == weight_of_radius.end()) --near;
        solid_weight += near->second / particle_volume(near->first, dim) * particle_volume(r, dim);
        continue;
      }
      it = weight_of_radius.emplace(r, psm_weight_sum(r, dim, tau, weight)).first;
    }
    solid_weight += it->second;
  }
  return total_volume - solid_weight;
}

std::array<double, 3> balancing_body_force(const dem::HostParticles& p, int dim, const std::array<double, 3>& g,
                                           double fluid_density, double total_volume, double tau, PsmWeight weight) {
  double net_mass = 0;
  for (Index i = 0; i < p.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double v = particle_volume(p.r[k], dim);
    // In 2D the DEM mass is that of a sphere; the disk's areal mass is rho_s pi r^2.
    const double rho_s = p.mass[k] / (4.0 / 3.0 * M_PI * p.r[k] * p.r[k] * p.r[k]);
    const double m = dim == 3 ? p.mass[k] : rho_s * v;
    net_mass += m - fluid_density * v;
  }
  const double vf = psm_fluid_weight(p, dim, total_volume, tau, weight);
  if (!(vf > 0))
    throw ConfigError("particles fill " + std::to_string(total_volume - vf) + " of the domain volume " +
                      std::to_string(total_volume) + " (lattice units): no fluid left to balance their weight");
  return {-net_mass * g[0] / vf, -net_mass * g[1] / vf, -net_mass * g[2] / vf};
}

CoupledSolver::CoupledSolver(lbm::LbmSolver& fluid, dem::DemSystem& dem, const CoupledParams& params)
    : fluid_(fluid), dem_(dem), p_(params), loop_(dem, *this, params.dem_substeps) {
  if (p_.dem_substeps < 1)
    throw ConfigError("coupling.dem_substeps = " + std::to_string(p_.dem_substeps) + ": must be >= 1");
  if (dem_.backend() != fluid_.backend())
    throw ConfigError(std::string("coupling: the DEM runs on ") + to_string(dem_.backend()) + " but the fluid on " +
                      to_string(fluid_.backend()) + "; both must use the same backend");
  if (!dem_.view().ext_force)
    throw ConfigError("coupling: the DEM system was created without external forcing (DemParams.external_forcing)");
  dim_ = fluid_.setup().lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  psm_ = std::make_unique<PsmCoupling>(fluid_, p_.slots);
  p_.psm.map.keep_overflow = true;
  map();
  check_overflow();
}

CoupledSolver::~CoupledSolver() = default;

PsmParticles CoupledSolver::particle_view() {
  // The DEM's records are Real4 (x, y, z, w): read them in place with stride 4.
  const dem::ParticleView v = dem_.view();
  PsmParticles p;
  p.x = &v.pos_r->x;
  p.y = &v.pos_r->y;
  p.z = dim_ == 3 ? &v.pos_r->z : nullptr;
  p.r = &v.pos_r->w;
  p.vx = &v.vel_im->x;
  p.vy = &v.vel_im->y;
  p.vz = &v.vel_im->z;
  p.wx = &v.omega_ii->x;
  p.wy = &v.omega_ii->y;
  p.wz = &v.omega_ii->z;
  p.n = v.n;
  p.stride = 4;
  if (v.n == 0) p = PsmParticles{};
  return p;
}

void CoupledSolver::map() { psm_->map(particle_view(), p_.psm, false); }

// The fluid side of the coupled step (the step itself: dem/coupled_loop.hpp).
// 1. Fluid step with the solid term; hydrodynamic force + buoyancy -> DEM coupling input.
void CoupledSolver::fluid_step(const dem::ParticleView& v) {
  ForceOut out;
  out.force = &v.ext_force->x;
  out.torque = &v.ext_torque->x;
  out.fstride = out.tstride = 4;
  if (p_.buoyancy)
    for (int a = 0; a < 3; ++a) out.per_volume[static_cast<std::size_t>(a)] = -p_.fluid_density * p_.gravity[static_cast<std::size_t>(a)];
  psm_->step(particle_view(), p_.psm, out);  // no particles: the plain LBM kernel
}

// 3. Remap the particles (possibly reordered by a neighbour-list rebuild) to cells.
void CoupledSolver::particles_moved(const dem::ParticleView&) { map(); }

// 4. The slot-overflow check every overflow_check_every steps.
void CoupledSolver::after_step(long steps_done) {
  if (p_.overflow_check_every > 0 && steps_done % p_.overflow_check_every == 0) check_overflow();
}

void CoupledSolver::advance(long n) {
  for (long i = 0; i < n; ++i) step();
}

void CoupledSolver::check_overflow() {
  const OverflowReport r = psm_->overflow();
  if (!r.overflow && !r.radius_too_large) return;
  // Name particles by global id (storage indices change at DEM rebuilds).
  const dem::HostParticles hp = dem_.download();
  std::ostringstream m;
  m << "PSM cell slots overflowed at coupled step " << loop_.steps() << ": ";
  if (r.overflow) {
    m << r.message << " Particle ids (storage index -> id):";
    for (int pi : r.particles)
      if (pi >= 0 && pi < static_cast<int>(hp.id.size())) m << ' ' << pi << "->" << hp.id[static_cast<std::size_t>(pi)];
    m << ". Raise coupling.slots (K) or check the particles for overlaps.";
  } else {
    m << r.message;
  }
  psm_->clear_overflow();
  throw ResourceError(m.str());
}

namespace {
// x, y, z of n Real4 records on a backend, as 3n doubles on the host.
std::vector<double> xyz_host(Backend b, const dem::Real4* d, Index n) {
  std::vector<dem::Real4> tmp(static_cast<std::size_t>(n));
  backend_copy_to_host(b, tmp.data(), d, sizeof(dem::Real4) * tmp.size());
  std::vector<double> out;
  out.reserve(3 * tmp.size());
  for (const auto& r : tmp) out.insert(out.end(), {r.x, r.y, r.z});
  return out;
}
}  // namespace

std::vector<double> CoupledSolver::solid_fraction_host() { return output_slots().total_eps_host(); }

const CellSlots& CoupledSolver::output_slots() { return psm_->output_slots(particle_view(), p_.psm); }

std::vector<double> CoupledSolver::hydro_force_host() const {
  const dem::ParticleView v = const_cast<dem::DemSystem&>(dem_).view();
  return xyz_host(fluid_.backend(), v.ext_force, v.n);
}

std::vector<double> CoupledSolver::hydro_torque_host() const {
  const dem::ParticleView v = const_cast<dem::DemSystem&>(dem_).view();
  return xyz_host(fluid_.backend(), v.ext_torque, v.n);
}

}  // namespace lbdem::imb
