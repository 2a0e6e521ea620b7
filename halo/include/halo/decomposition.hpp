#pragma once
// Cartesian domain decomposition: which piece of the global grid each rank
// owns, and who its neighbours are. The physics modules read only the Grid of
// their piece (core/grid.hpp); this header is where ranks become pieces.
//
// Rank r sits at Cartesian coordinates (i, j, k) with r = i + dims[0] (j +
// dims[1] k). Along an axis cut into d parts, part i owns n / d cells, the
// first n % d parts one more (uneven splits allowed). The cut is chosen to
// move the fewest halo cells; ties go to fewer split axes (fewer messages),
// then to cuts along z, then y (whole x rows stay contiguous in memory).
#include <array>
#include <string>

#include "core/grid.hpp"

namespace lbdem::halo {

struct Decomposition {
  std::array<int, 3> dims{1, 1, 1};  // ranks per axis
  std::array<long, 3> global{1, 1, 1};
  std::array<bool, 3> periodic{true, true, true};

  int ranks() const { return dims[0] * dims[1] * dims[2]; }
  std::array<int, 3> coords(int rank) const;
  int rank_at(std::array<int, 3> c) const;
  // The rank across face `dir` (-1 or +1) of axis `axis` from `rank`, or -1
  // where a non-periodic axis ends.
  int neighbour(int rank, int axis, int dir) const;
  // Rank r's piece of `whole` (whole's origin, spacing and periodic flags are
  // kept), with `ghost` layers on every split axis.
  Grid piece(const Grid& whole, int rank, int ghost = 1) const;
  // Cells that cross cut faces per step in one direction (the halo volume
  // the choice minimises): sum over cut faces of the face area.
  double halo_cells() const;
  std::string describe() const;  // "2 x 1 x 2"
};

// Smallest number of owned cells a rank keeps along a split axis.
inline constexpr long kMinCellsPerRank = 2;

// The decomposition of `whole` over `ranks` ranks; `requested` gives the
// ranks per axis (all three > 0) or {0, 0, 0} to choose. Throws ConfigError
// (naming `key`, the value and what would work) when the ranks cannot fit.
Decomposition decompose(const Grid& whole, int ranks, std::array<int, 3> requested = {0, 0, 0},
                        const std::string& key = "decomposition");

}  // namespace lbdem::halo
