// LaggedCoupling: the gas step beside the DEM sub-steps (cfd/lagged_coupling.hpp).
#include "cfd/lagged_coupling.hpp"

#include <string>

#include "core/error.hpp"

namespace lbdem::cfd {

namespace {

// The gas step's copy of particle i at the start of the step.
struct TakeParticles {
  const dem::Real4* pos;
  const dem::Real4* vel;
  const std::int64_t* id;
  dem::Real4* pos_copy;
  dem::Real4* vel_copy;
  std::int64_t* id_copy;
  LBDEM_HD void operator()(Index i) const {
    pos_copy[i] = pos[i];
    vel_copy[i] = vel[i];
    id_copy[i] = id[i];
  }
};

// slot[id] = storage index of the particle with that id now.
struct SlotOfId {
  const std::int64_t* id;
  int* slot;
  LBDEM_HD void operator()(Index i) const { slot[id[i]] = static_cast<int>(i); }
};

// The forces the gas step computed (in the order of its copy) into the
// coupling input (in the order after the sub-steps).
struct GiveForces {
  const std::int64_t* id;
  const int* slot;
  const dem::Real4* force;
  dem::Real4* ext_force;
  LBDEM_HD void operator()(Index j) const { ext_force[slot[id[j]]] = force[j]; }
};

}  // namespace

LaggedCoupling::LaggedCoupling(const Exec& main, const Lanes& lanes, dem::DemSystem& dem, GasSolver& gas,
                               int substeps, std::int64_t id_limit)
    : main_(main), lanes_(lanes), dem_(dem), gas_(gas), substeps_(substeps), n_(dem.size()) {
  if (dem.global_size() != n_)
    throw ConfigError("gas.force_coupling = lagged: runs on one rank (the particles are handed over by id)");
  // The id -> storage index table is as long as the id range: refuse a range
  // far beyond the particle count rather than hold a table mostly empty.
  if (id_limit < 0 || id_limit > 4 * static_cast<std::int64_t>(n_) + 1024)
    throw ConfigError("gas.force_coupling = lagged: particle ids up to " + std::to_string(id_limit - 1) + " for " +
                      std::to_string(n_) + " particles (valid: ids below 4 x the particle count + 1024); use "
                      "gas.force_coupling: sequential");
  const Backend b = main.backend();
  const Index m = n_ > 0 ? n_ : 1;
  pos_ = Buffer<dem::Real4>(b, m);
  vel_ = Buffer<dem::Real4>(b, m);
  force_ = Buffer<dem::Real4>(b, m);
  id_ = Buffer<std::int64_t>(b, m);
  slot_ = Buffer<int>(b, id_limit > 0 ? static_cast<Index>(id_limit) : 1);
}

void LaggedCoupling::step(bool first) {
  if (first) {
    lanes_.fork(main_);  // the gas waits for the particles as they are
    gas_.step(dem_.view());
    lanes_.join(main_);  // the sub-steps wait for its forces
    dem_.advance(substeps_);
    return;
  }
  dem::ParticleView p = dem_.view();
  for_each(main_, n_, TakeParticles{p.pos_r, p.vel_im, dem_.ids(), pos_.data(), vel_.data(), id_.data()});
  lanes_.fork(main_);  // the gas step waits for its copy (and everything queued before it)
  dem::ParticleView q{};
  q.pos_r = pos_.data();
  q.vel_im = vel_.data();
  q.ext_force = force_.data();
  q.n = n_;
  gas_.step(q);             // second queue
  dem_.advance(substeps_);  // main queue, with the forces of the previous gas step
  lanes_.join(main_);       // what follows on the main queue waits for the gas step
  p = dem_.view();
  for_each(main_, n_, SlotOfId{dem_.ids(), slot_.data()});
  for_each(main_, n_, GiveForces{id_.data(), slot_.data(), force_.data(), p.ext_force});
}

}  // namespace lbdem::cfd
