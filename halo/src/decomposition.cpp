#include "halo/decomposition.hpp"

#include <limits>
#include <sstream>

#include "core/error.hpp"

namespace lbdem::halo {

std::array<int, 3> Decomposition::coords(int rank) const {
  return {rank % dims[0], (rank / dims[0]) % dims[1], rank / (dims[0] * dims[1])};
}

int Decomposition::rank_at(std::array<int, 3> c) const { return c[0] + dims[0] * (c[1] + dims[1] * c[2]); }

int Decomposition::neighbour(int rank, int axis, int dir) const {
  auto c = coords(rank);
  const auto a = static_cast<std::size_t>(axis);
  c[a] += dir;
  if (c[a] < 0 || c[a] >= dims[a]) {
    if (!periodic[a]) return -1;
    c[a] = (c[a] + dims[a]) % dims[a];
  }
  return rank_at(c);
}

Grid Decomposition::piece(const Grid& whole, int rank, int ghost) const {
  Grid g = whole;
  const auto c = coords(rank);
  g.ghost = ghost;
  for (std::size_t a = 0; a < 3; ++a) {
    const long n = global[a], d = dims[a];
    const long base = n / d, extra = n % d, i = c[a];
    g.local[a] = base + (i < extra ? 1 : 0);
    g.offset[a] = i * base + (i < extra ? i : extra);
    g.split[a] = d > 1;
  }
  return g;
}

double Decomposition::halo_cells() const {
  double total = 0;
  for (std::size_t a = 0; a < 3; ++a) {
    if (dims[a] == 1) continue;
    const double faces = periodic[a] ? dims[a] : dims[a] - 1;
    const double area = static_cast<double>(global[(a + 1) % 3]) * static_cast<double>(global[(a + 2) % 3]);
    total += faces * area;
  }
  return total;
}

std::string Decomposition::describe() const {
  std::ostringstream o;
  o << dims[0] << " x " << dims[1] << " x " << dims[2];
  return o.str();
}

namespace {
bool fits(const std::array<long, 3>& n, const std::array<int, 3>& d) {
  for (std::size_t a = 0; a < 3; ++a)
    if (d[a] > 1 && n[a] / d[a] < kMinCellsPerRank) return false;
  return true;
}
int split_axes(const std::array<int, 3>& d) { return (d[0] > 1) + (d[1] > 1) + (d[2] > 1); }
}  // namespace

Decomposition decompose(const Grid& whole, int ranks, std::array<int, 3> requested, const std::string& key) {
  Decomposition dec;
  dec.global = whole.global;
  dec.periodic = whole.periodic;
  const bool two_d = whole.global[2] == 1;
  if (ranks < 1) throw ConfigError("key '" + key + "': " + std::to_string(ranks) + " ranks: need at least one");
  auto grid_text = [&] {
    return std::to_string(whole.global[0]) + " x " + std::to_string(whole.global[1]) + " x " +
           std::to_string(whole.global[2]);
  };
  if (requested[0] > 0 || requested[1] > 0 || requested[2] > 0) {
    dec.dims = requested;
    const std::string given = "[" + std::to_string(requested[0]) + ", " + std::to_string(requested[1]) + ", " +
                              std::to_string(requested[2]) + "]";
    for (int v : requested)
      if (v < 1) throw ConfigError("key '" + key + "' = " + given + ": every entry must be >= 1");
    if (dec.ranks() != ranks)
      throw ConfigError("key '" + key + "' = " + given + " makes " + std::to_string(dec.ranks()) +
                        " pieces but the run has " + std::to_string(ranks) + " ranks; the product must equal the rank count");
    if (two_d && requested[2] != 1)
      throw ConfigError("key '" + key + "' = " + given + ": a 2D grid cannot be cut along z (use [nx, ny, 1])");
    if (!fits(whole.global, requested))
      throw ConfigError("key '" + key + "' = " + given + ": the grid " + grid_text() + " leaves fewer than " +
                        std::to_string(kMinCellsPerRank) + " cells per rank along a cut axis");
    return dec;
  }
  double best = std::numeric_limits<double>::infinity();
  bool found = false;
  Decomposition cand = dec;
  for (int dz = two_d ? 1 : ranks; dz >= 1; --dz) {
    if (ranks % dz) continue;
    for (int dy = ranks / dz; dy >= 1; --dy) {
      if ((ranks / dz) % dy) continue;
      const int dx = ranks / dz / dy;
      cand.dims = {dx, dy, dz};
      if (!fits(whole.global, cand.dims)) continue;
      const double h = cand.halo_cells();
      // Strictly better halo, or equal halo with fewer split axes; the loop
      // order makes z, then y, win remaining ties.
      if (!found || h < best * (1 - 1e-12) ||
          (h <= best * (1 + 1e-12) && split_axes(cand.dims) < split_axes(dec.dims))) {
        best = h;
        dec.dims = cand.dims;
        found = true;
      }
    }
  }
  if (!found) {
    long most = 1;
    for (std::size_t a = 0; a < (two_d ? 2u : 3u); ++a) most *= std::max(1L, whole.global[a] / kMinCellsPerRank);
    throw ConfigError("the grid " + grid_text() + " cannot be cut into " + std::to_string(ranks) +
                      " pieces with at least " + std::to_string(kMinCellsPerRank) +
                      " cells per rank along each cut axis; run on at most " + std::to_string(most) +
                      " ranks or use a larger grid");
  }
  return dec;
}

}  // namespace lbdem::halo
