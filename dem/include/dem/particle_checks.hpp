#pragma once
// Checks of a case's particles while it is parsed: particles against the box
// (a centre outside the domain or behind a wall, a particle wider than the
// box), particles that overlap each other or a wall (such contacts give
// forces that blow the run up within a few steps), random packings that
// cannot fit, and the particles' memory (core/run_checks.hpp).
#include <array>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/exec.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

// The box the particles must lie in: the DEM box (lo, hi, periodic axes,
// walls). `dim` = 2 skips the z axis (a 2D scene's particles are disks in a
// one-cell-thick slab). `key` names the particles' section for messages,
// `box_key` the key that sets the box.
struct ParticleBox {
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};
  std::array<bool, 3> periodic{false, false, false};
  std::vector<Wall> walls;
  int dim = 3;
  std::string key = "particles";
  std::string box_key = "domain";
  std::string walls_key = "walls";
};
ParticleBox particle_box(const DemParams& p, int dim, const std::string& box_key, const std::string& walls_key);

// Deepest overlap accepted between two particles or a particle and a wall,
// as a fraction of the smaller radius: touching particles, and pre-loaded
// contacts such as the stacked-spheres test of Yu et al. (cases/
// dem_03_stacked_particles.yaml, 10 %), pass; coincident or deeply
// interpenetrating particles, whose contact forces blow the run up in its
// first steps, do not.
constexpr double kMaxInitialOverlap = 0.2;

// Throws ConfigError (file, key, particle id, how far, what to change).
void check_particles_in_box(const Config& root, const HostParticles& p, const ParticleBox& box);
void check_particle_overlaps(const Config& root, const HostParticles& p, const ParticleBox& box);

// Bytes per DEM particle: host copies (the case's HostParticles and the
// solver's download) and the solver's own arrays (state, sort, cell and
// neighbour lists): a lower bound, so that a refusal is certain.
constexpr double kDemHostBytesPerParticle = 2 * 152.0;
constexpr double kDemDeviceBytesPerParticle = 400.0;

// Host memory of `count` particles before they are made (`key` of `pc` sets the count).
void check_dem_particle_count(const Config& pc, double count, const std::string& key);
// The fewest particles of a random packing at this solid fraction (all of the largest radius).
double random_packing_count(const std::array<double, 3>& lo, const std::array<double, 3>& hi, double solid_fraction,
                            double r_max, int dim = 3);
// A random packing (dem::random_packing) of the box [lo, hi]: the largest
// particle fits along every axis, and the particles' host memory.
void check_random_fill(const Config& pc, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                       const std::array<bool, 3>& periodic, double r_max, const std::string& box_key);
void check_dem_random_packing(const Config& pc, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                              const std::array<bool, 3>& periodic, double solid_fraction, double r_max);

// The dem scene's particles while its case is parsed: against the box and
// walls (domain.lo, domain.hi; walls), overlaps, memory (`backend`: the one
// the run will use) and the plan (`force`: --force; `steps_given`: --steps set
// the step count, else time.steps or time.end over the DEM time step p.dt).
void check_dem_scene(const Config& root, const DemParams& p, const HostParticles& hp, long steps, Backend backend,
                     bool force, bool steps_given);
}  // namespace lbdem::dem
