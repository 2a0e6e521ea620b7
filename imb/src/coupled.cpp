#include "imb/coupled.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "core/buffer.hpp"
#include "core/error.hpp"

namespace lbdem::imb {

namespace {
double particle_volume(double r, int dim) {
  return dim == 3 ? 4.0 / 3.0 * M_PI * r * r * r : M_PI * r * r;
}
}  // namespace

std::array<double, 3> balancing_body_force(const dem::HostParticles& p, int dim, const std::array<double, 3>& g,
                                           double fluid_density, double total_volume) {
  if (!(total_volume > 0))
    throw ConfigError("balancing body force: domain volume " + std::to_string(total_volume) +
                      " (lattice units) must be > 0");
  double net_mass = 0;
  for (Index i = 0; i < p.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    net_mass += p.mass[k] - fluid_density * particle_volume(p.r[k], dim);
  }
  return {-net_mass * g[0] / total_volume, -net_mass * g[1] / total_volume, -net_mass * g[2] / total_volume};
}

CoupledSolver::CoupledSolver(lbm::LbmSolver& fluid, dem::DemSystem& dem, const CoupledParams& params,
                             CoupledRanks ranks)
    : fluid_(fluid), dem_(dem), p_(params), ranks_(ranks), loop_(dem, *this, params.dem_substeps) {
  if (p_.dem_substeps < 1)
    throw ConfigError(p_.keys.dem_substeps + " = " + std::to_string(p_.dem_substeps) + ": must be >= 1");
  if (dem_.backend() != fluid_.backend())
    throw ConfigError(std::string("coupling: the DEM runs on ") + to_string(dem_.backend()) + " but the fluid on " +
                      to_string(fluid_.backend()) + "; both must use the same backend");
  if (!dem_.params().external_forcing)
    throw ConfigError("coupling: the DEM system was created without external forcing (DemParams.external_forcing)");
  dim_ = fluid_.setup().lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  psm_ = std::make_unique<PsmCoupling>(fluid_, p_.slots);
  clock_ = std::make_unique<PhaseClock>(fluid_.backend(), std::vector<std::string>(std::begin(kPhaseNames), std::end(kPhaseNames)));
  p_.psm.map.keep_overflow = true;
  if (p_.wall_lubrication.applied && dim_ != 3)
    throw ConfigError("coupling: the wall gap correction is fitted for spheres (3D), not for this 2D scene");
  // A body force on the fluid here is the balancing mean pressure gradient
  // (balancing_body_force): the particles take it on their share of each cell.
  p_.psm.body_force_on_solid = true;
  if (!ranks_.distributed()) ranks_ = CoupledRanks{};
  map();
  check_overflow();
}

CoupledSolver::~CoupledSolver() = default;

namespace {

// The DEM's records are Real4 (x, y, z, w): the PSM reads them in place with
// stride 4 (z only in 3D). No particles: no arrays.
PsmParticles psm_particles(const dem::ParticleView& v, int dim) {
  PsmParticles p;
  if (v.n == 0) return p;
  p.x = &v.pos_r->x;
  p.y = &v.pos_r->y;
  p.z = dim == 3 ? &v.pos_r->z : nullptr;
  p.r = &v.pos_r->w;
  p.vx = &v.vel_im->x;
  p.vy = &v.vel_im->y;
  p.vz = &v.vel_im->z;
  p.wx = &v.omega_ii->x;
  p.wy = &v.omega_ii->y;
  p.wz = &v.omega_ii->z;
  p.n = v.n;
  p.stride = 4;
  return p;
}

}  // namespace

PsmParticles CoupledSolver::particle_view() {
  return psm_particles(ranks_.halo ? dem_.held_view() : dem_.view(), dim_);
}

void CoupledSolver::map() {
  // The ghosts take their owners' current velocities first (the solid
  // velocity of their cells here); a no-op on one rank.
  if (ranks_.halo) dem_.sync_ghosts();
  clock_->mark(3);
  psm_->map(particle_view(), p_.psm, false);
  clock_->mark(4);
}

// The fluid side of the coupled step (the step itself: dem/coupled_loop.hpp).
// 1. Fluid step with the solid term; hydrodynamic force + buoyancy -> DEM coupling input.
void CoupledSolver::fluid_step(const dem::ParticleView& v) {
  ForceOut out;
  // (A rank of a decomposed run may hold no particle: no arrays then.)
  out.force = v.ext_force ? &v.ext_force->x : nullptr;
  out.torque = v.ext_torque ? &v.ext_torque->x : nullptr;
  out.fstride = out.tstride = 4;
  if (p_.buoyancy)
    for (int a = 0; a < 3; ++a) out.per_volume[static_cast<std::size_t>(a)] = -p_.fluid_density * p_.gravity[static_cast<std::size_t>(a)];
  clock_->begin_step();
  if (!ranks_.halo) {
    psm_->step(particle_view(), p_.psm, out);  // no particles: the plain LBM kernel
    add_wall_lubrication(v);
    clock_->mark(0);
    return;
  }
  // This rank's share of every particle it holds (owned first, then ghosts,
  // which share the arrays behind them); the buoyancy on the owned only.
  out.per_volume_count = v.n;
  psm_->step(particle_view(), p_.psm, out, *ranks_.halo);
  clock_->mark(0);
  dem_.return_ghost_coupling();
  add_wall_lubrication(v);
  clock_->mark(1);
}

// The wall gap correction on the owned particles' summed hydrodynamic force
// (same queue as the gather: ordered after it, no host round trip).
void CoupledSolver::add_wall_lubrication(const dem::ParticleView& v) {
  if (!p_.wall_lubrication.applied || v.n == 0 || v.ext_force == nullptr) return;
  imb::add_wall_lubrication(fluid_.exec(lbm::Lane::Main), p_.wall_lubrication.k, psm_particles(v, 3), v.n,
                            &v.ext_force->x, 4);
}

// 3. Remap the particles (possibly reordered by a neighbour-list rebuild) to cells.
void CoupledSolver::particles_moved(const dem::ParticleView&) {
  clock_->mark(2);  // the DEM sub-steps since the fluid step
  map();
  clock_->end_step();
}

// 4. The slot-overflow check every overflow_check_every steps.
void CoupledSolver::after_step(long steps_done) {
  if (p_.overflow_check_every > 0 && steps_done % p_.overflow_check_every == 0) check_overflow();
}

void CoupledSolver::load_state(ckpt::Source& in) {
  const auto steps = in.get<std::int64_t>();
  if (steps < 0) in.mismatch("a negative coupled step count");
  loop_.restore_steps(static_cast<long>(steps));
  map();
}

void CoupledSolver::advance(long n) {
  for (long i = 0; i < n; ++i) step();
}

void CoupledSolver::check_overflow() {
  const OverflowReport r = psm_->overflow();
  const bool mine = r.overflow || r.radius_too_large;
  if (ranks_.comm && ranks_.comm->any(mine) && !mine) {
    psm_->clear_overflow();
    throw ResourceError("PSM cell slots overflowed at coupled step " + std::to_string(loop_.steps()) +
                        " on another rank (its message names the cell and the particles)");
  }
  if (!mine) return;
  // Name particles by global id (storage indices change at DEM rebuilds).
  const dem::HostParticles hp = dem_.download();
  std::ostringstream m;
  m << "PSM cell slots overflowed at coupled step " << loop_.steps() << ": ";
  if (r.overflow) {
    m << r.message << " Particle ids (storage index -> id):";
    for (int pi : r.particles)
      if (pi >= 0 && pi < static_cast<int>(hp.id.size())) m << ' ' << pi << "->" << hp.id[static_cast<std::size_t>(pi)];
    m << ". Raise " << p_.keys.slots << " (K) or check the particles for overlaps.";
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

void CoupledSolver::solid_fraction_box(const CellBox& box, double* eps) {
  psm_->solid_fraction_box(particle_view(), p_.psm, box, eps);
}

void CoupledSolver::solid_fraction_device(const CellBox& box, double* out) {
  psm_->solid_fraction_device(particle_view(), p_.psm, box, out);
}

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
