#pragma once
// Random particle sets of a suspension's set-up: random disks on a jittered
// lattice, block packings cut to a rank's piece, random initial velocities.
#include <array>
#include <cstdint>
#include <string>

#include "dem/block_packing.hpp"
#include "dem/domain.hpp"
#include "dem/particles.hpp"

namespace lbdem::dem {

// `count` non-overlapping disks of radius r (centres at z = 0.5: a 2D scene's
// one-cell slab) in the box [lo, hi] of x and y: a random subset of the sites
// of a square lattice with about twice as many sites as disks (fewer where the
// disks need the room), each disk displaced by a uniform random offset of up
// to half the free gap along each axis, so no two disks overlap. O(count).
// Masses as HostParticles::add (rho 4/3 pi r^3, the DEM's 2D convention).
// Throws ConfigError naming `key` when the box cannot hold them.
HostParticles random_disks(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                                const std::array<bool, 3>& periodic, long count, double r, double density,
                                std::uint64_t seed, const std::string& key);

// The particles of a random suspension packed in blocks (particles.packing:
// blocks; dem/block_packing.hpp): the same set whatever the rank count, each
// rank generating only its own. `domain` null or not decomposed: every
// particle; else the particles whose centre lies in this rank's piece
// (DemDomain::owner), which is what DemSystem keeps of them. Collective on
// several ranks: throws ConfigError on every rank when a piece holds no
// particle (the DEM sizes its cell grid from the radii it is given).
HostParticles suspension_blocks(const BlockPackingSpec& spec, const DemDomain* domain);

// Adds to every particle's velocity a random vector of length `speed`, its
// direction uniform on the sphere (3D) or the circle in the x-y plane (2D);
// then removes the mean of the added vectors, so that the particles' total
// momentum is what it was (a weight-balanced periodic suspension starts at
// rest as a whole). Deterministic for a seed.
void add_random_velocities(HostParticles& p, int dim, double speed, std::uint64_t seed);

}  // namespace lbdem::dem
