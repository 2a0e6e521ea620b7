#pragma once
// The DEM box cut into one piece per rank (dem/README.md, "Many ranks"). A
// particle belongs to the rank whose piece holds its centre; the pieces are
// the Cartesian pieces of a halo::Decomposition mapped onto the box in
// physical coordinates, so that a coupled scene cuts its particles where it
// cuts its lattice.
#include <array>
#include <string>
#include <vector>

#include "core/vec.hpp"
#include "dem/particles.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/transport.hpp"

namespace lbdem::dem {

struct DemParams;

struct DemDomain {
  const halo::Comm* comm = nullptr;  // null: one rank
  halo::Decomposition dec;           // ranks per axis; rank r at dec.coords(r)
  // Boundaries of the pieces along each axis [m]: dims[a] + 1 increasing
  // values, the first the box's lo, the last its hi; part i of axis a spans
  // [cuts[a][i], cuts[a][i + 1]).
  std::array<std::vector<double>, 3> cuts;
  // How the per-step ghost refresh travels (halo/transport.hpp).
  halo::TransportKind transport = halo::TransportKind::Auto;

  // More than one rank: particles migrate and ghosts are exchanged.
  bool decomposed() const { return comm != nullptr && comm->size() > 1; }
  int rank() const { return comm ? comm->rank() : 0; }
  // Part of axis a holding coordinate x (clamped into the first / last part:
  // a particle beyond a closed face stays with the edge piece).
  int part(int a, double x) const;
  // The rank whose piece holds position x (x wrapped on periodic axes).
  int owner(const Vec3d& x) const;
  // Lower and upper corner of rank r's piece [m].
  void piece(int r, Vec3d& lo, Vec3d& hi) const;
};

// Width of the layer of ghosts a piece needs beyond its faces [m]: the
// largest neighbour-list cutoff 2 r_max + skin (the skin as DemSystem sets it:
// DemParams::skin, or 0.2 r_min when that is 0). Every partner that the list
// of an owned particle can hold lies within it of the piece.
double ghost_width(const DemParams& p, const std::vector<double>& radii);

// The pieces of the box p.lo..p.hi for the lattice decomposition `dec` of a
// grid of dec.global cells spanning the box: cut a after global cell offset o
// lies at lo + (hi - lo) o / global.
DemDomain domain_from_decomposition(const halo::Comm& comm, const halo::Decomposition& dec, const DemParams& p);

// A decomposition of a pure DEM scene over comm.size() ranks: halo::decompose
// over a grid of cells at least the ghost width wide (so every automatically
// chosen piece is thick enough), `requested` ranks per axis or {0, 0, 0} to
// choose (fewest cut faces). Throws ConfigError naming `key` when it cannot
// be done.
DemDomain decompose_box(const halo::Comm& comm, const DemParams& p, const HostParticles& hp,
                        std::array<int, 3> requested = {0, 0, 0}, const std::string& key = "decomposition");

}  // namespace lbdem::dem
