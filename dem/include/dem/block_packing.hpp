#pragma once
// A random packing of equal spheres (or disks) that each rank of a
// decomposed run generates for its own piece only, the same particles
// whatever the rank count (DESIGN.md, "Nothing whole on one rank").
//
// The sites are those of one lattice over the whole box: face-centred cubic
// in 3D (the points of a cubic grid of spacing h with i + j + k even), square
// in 2D (centres in the plane z = 0.5), about two sites per particle where the
// particles leave the room (never closer than a diameter). The lattice is cut
// into fixed blocks of sites (kBlockEdge3d / kBlockEdge2d sites per axis);
// block b holds n_b particles, the largest-remainder rounding of
// count x sites_b / sites (so the count is exact and every block is filled to
// the same fraction to within one particle), on a uniform random subset of its
// own sites drawn from its own stream (the seed mixed with b). Each particle
// is then displaced from its site by a uniform random vector in the ball (3D)
// or disk (2D) of radius (nn - 2 r) / 2, nn the lattice's nearest-neighbour
// distance: two particles on different sites stay at least nn - 2 (nn - 2 r)
// / 2 = 2 r apart, whichever blocks they come from, so no exclusion test
// across block faces is needed. Ids run block by block (block b's first id is
// the sum of the counts of blocks 0 .. b - 1), velocities come from a second
// stream per block, their block mean removed (the whole set's added momentum
// is then zero, summed block by block).
//
// A rank generates the blocks whose sites lie within the displacement of its
// piece, O(particles of the piece plus a layer of blocks around it), and keeps
// the particles whose centre its predicate accepts; the plan (block counts and
// first ids) is O(blocks) on every rank.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/vec.hpp"
#include "dem/particles.hpp"

namespace lbdem::dem {

struct BlockPackingSpec {
  int dim = 3;                                   // 2: disks in the plane z = 0.5 (lo/hi of z unused)
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};  // the box the centres fill
  std::array<bool, 3> periodic{true, true, true};
  long count = 0;       // particles in the box
  double radius = 0.5;  // every particle's
  double density = 1;   // mass as HostParticles::add (4/3 pi r^3 rho, also in 2D)
  double speed = 0;     // random velocity of this magnitude, isotropic (in the x-y plane in 2D), block mean removed
  Vec3d velocity{0, 0, 0};          // added to every particle's
  Vec3d angular_velocity{0, 0, 0};  // every particle's
  std::uint64_t seed = 1;
  // false: every particle on its site (no displacement): the count, radii,
  // masses and ids of the run at a fraction of the cost (`lbdem check`).
  bool displace = true;
};

class BlockPacking {
 public:
  static constexpr long kBlockEdge3d = 8;   // sites per block edge: 8^3 / 2 = 256 FCC sites
  static constexpr long kBlockEdge2d = 16;  // 16^2 = 256 square-lattice sites

  // The lattice and the plan (every block's count and first id). Throws
  // ConfigError when the box cannot hold `count` particles of this radius.
  explicit BlockPacking(const BlockPackingSpec& spec);

  // The particles whose centre lies in the box [lo, hi) (positions as
  // generated: inside the spec's box, periodic axes wrapped) and that `keep`
  // accepts (null: all of them). Only the blocks that can hold such a centre
  // are generated.
  HostParticles pack(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                     const std::function<bool(const Vec3d&)>& keep = {}) const;
  // Every particle, in id order.
  HostParticles pack_all() const;

  long count() const { return spec_.count; }
  long blocks() const { return static_cast<long>(first_id_.size()); }
  std::array<long, 3> sites_per_axis() const { return m_; }
  std::array<long, 3> blocks_per_axis() const { return nb_; }
  long sites() const { return sites_; }
  long block_count(long b) const { return count_[static_cast<std::size_t>(b)]; }
  long block_sites(long b) const;  // lattice sites of block b
  double nearest_neighbour() const { return nn_; }
  double displacement() const { return jitter_; }  // largest distance of a centre from its site
  // Particles generated (kept or not) by the last pack() / pack_all() call:
  // the work and scratch a rank spends beyond its own particles.
  long generated() const { return generated_; }

 private:
  // Appends block b's particles that pass the box and `keep` tests.
  void block(long b, HostParticles& out, const std::array<double, 3>* lo, const std::array<double, 3>* hi,
             const std::function<bool(const Vec3d&)>& keep) const;
  BlockPackingSpec spec_;
  long edge_ = 8;
  std::array<long, 3> m_{1, 1, 1}, nb_{1, 1, 1};
  std::array<double, 3> rlo_{}, step_{};
  long sites_ = 0;
  double nn_ = 0, jitter_ = 0;
  std::vector<long> count_, first_id_;
  mutable long generated_ = 0;
};

}  // namespace lbdem::dem
