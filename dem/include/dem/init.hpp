#pragma once
// Initial particle sets for scenes and tests (host side).
#include <array>
#include <cstdint>
#include <string>

#include "dem/particles.hpp"

namespace lbdem::dem {

// CSV with a header line naming the columns; required x,y,z,r; optional
// vx,vy,vz, wx,wy,wz, density (else default_density), id, type. Units SI.
// Throws ConfigError naming the file, the line and the column on bad input.
HostParticles read_particles_csv(const std::string& path, double default_density);

// A particle snapshot written by the DEM scene driver (io::ParticleWriter
// datasets): positions and radius required; velocity, angular_velocity, id,
// mass (else from default_density) used when present. Restarts a settled bed.
HostParticles read_particles_h5(const std::string& path, double default_density);

// count[0] x count[1] x count[2] particles at origin + (i,j,k) * spacing.
HostParticles lattice_particles(const Vec3d& origin, const std::array<long, 3>& count, const Vec3d& spacing,
                                double radius, double density);

struct RandomPackingSpec {
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};
  std::array<bool, 3> periodic{true, true, true};
  double solid_fraction = 0.5;  // of the whole box
  double r_min = 0.5, r_max = 0.5;  // radii uniform in [r_min, r_max]
  double density = 1000;
  std::uint64_t seed = 1;
  int mc_sweeps = 0;  // hard-sphere Monte Carlo sweeps after placement (more random, O(N) each)
  // false: every particle on its lattice site (no displacement, no sweeps).
  // What validation (`lbdem check`) builds: the count, radii and masses are
  // the run's, and being inside the region and apart holds by construction
  // either way, at a fraction of the cost for millions of particles.
  bool displace = true;
};
// Random non-overlapping spheres at a given solid fraction: random subset of
// the sites of a face-centred-cubic lattice just dense enough, each particle
// displaced at random by up to half the free gap (never overlapping), then
// optional Monte Carlo sweeps. O(N).
// Throws ConfigError when the lattice cannot hold the radii at that fraction.
HostParticles random_packing(const RandomPackingSpec& spec);

}  // namespace lbdem::dem
