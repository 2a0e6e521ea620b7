#pragma once
// Link-wise boundaries applied where a fluid cell's outgoing population would
// enter a boundary cell (flag > 0). The reflected value is written where the
// fluid cell reads it next step, so loads stay branch-free.
//
//  Wall        half-way bounce-back:           f_qbar(x) = f*_q(x)
//  Velocity    Ladd moving wall / velocity inlet (Ladd 1994):
//                f_qbar(x) = f*_q(x) - 2 w_q rho_w (c_q . u_w) / cs^2
//  Pressure    anti-bounce-back (Ginzburg 2008), pressure outlet:
//                f_qbar(x) = -f*_q(x) + 2 w_q rho_w [1 + (c_q.u)^2/(2cs^4) - u^2/(2cs^2)],
//              u = velocity of the fluid cell x (first-order extrapolation to the wall).
// All three place the wall half-way between the fluid and the boundary cell.
#include <cstdint>

#include "core/hd.hpp"

namespace lbdem::lbm {

enum class BoundaryKind : int { Wall = 0, Velocity = 1, Pressure = 2 };

inline constexpr int kMaxBoundaries = 8;

// Flag of a ghost cell: a copy of a neighbour rank's cell, filled by the halo
// exchange. Streaming treats it as fluid (populations go into it and are sent
// on), never as a wall, and no kernel updates it.
inline constexpr std::uint8_t kGhostFlag = 0xFF;

// True if a cell with this flag reflects populations (boundary entries
// 1..kMaxBoundaries); false for fluid (0) and ghost cells. One comparison.
LBDEM_HD inline bool reflects(int flag) { return static_cast<unsigned>(flag - 1) < static_cast<unsigned>(kMaxBoundaries); }

// Boundary id k (flag value k, 1..kMaxBoundaries) -> entry k-1.
struct BoundaryTable {
  int count = 0;
  BoundaryKind kind[kMaxBoundaries]{};
  double u[kMaxBoundaries][3]{};  // lattice units
  double rho[kMaxBoundaries]{};   // lattice units
};

}  // namespace lbdem::lbm
