// Builds the solid-fraction lookup table (imb/fraction_table.hpp) with the
// exact method, on the host (OpenMP), once per run.
#include "imb/fraction_table.hpp"

#include <atomic>
#include <string>

#include "core/error.hpp"

namespace lbdem::imb {

namespace {
std::atomic<std::uint64_t> g_next_table_id{1};  // identifies tables for the device upload cache
}

FractionTable build_fraction_table(int dim, int nt, int nu, int nv, double r_fit_a, double r_fit_b) {
  if (dim != 2 && dim != 3) throw ConfigError("fraction table: dim = " + std::to_string(dim) + " (must be 2 or 3)");
  if (nt <= 0) nt = dim == 3 ? 32 : 64;
  if (nu <= 0) nu = dim == 3 ? 11 : 32;
  if (dim == 2) nv = 1;
  else if (nv <= 0) nv = 11;
  if (nt < 2 || nu < 2 || (dim == 3 && nv < 2))
    throw ConfigError("fraction table: node counts nt=" + std::to_string(nt) + " nu=" + std::to_string(nu) +
                      " nv=" + std::to_string(nv) + " must each be >= 2");
  if (!(r_fit_a > 1.0) || !(r_fit_b > 1.0) || r_fit_a == r_fit_b)
    throw ConfigError("fraction table: fit radii " + std::to_string(r_fit_a) + ", " + std::to_string(r_fit_b) +
                      " must be distinct and > 1 lattice unit");
  FractionTable tab;
  TableGeometry& g = tab.geometry;
  g.dim = dim;
  g.nt = nt;
  g.nu = nu;
  g.nv = nv;
  if (g.floats() > kTableCapacity)
    throw ConfigError("fraction table: " + std::to_string(nt) + "x" + std::to_string(nu) + "x" + std::to_string(nv) +
                      " nodes x 2 coefficients = " + std::to_string(g.floats()) + " floats exceeds the " +
                      std::to_string(kTableCapacity) + "-float (32 KB) constant-memory budget");
  tab.r_fit_a = r_fit_a;
  tab.r_fit_b = r_fit_b;
  tab.values.assign(static_cast<std::size_t>(g.floats()), 0.0f);
  const int nodes = g.nodes();
  const double ia = 1.0 / r_fit_a, ib = 1.0 / r_fit_b;
#pragma omp parallel for schedule(dynamic, 16)
  for (int idx = 0; idx < nodes; ++idx) {
    const int it = idx % nt, iu = (idx / nt) % nu, iv = idx / (nt * nu);
    const double t = g.t_min + (g.t_max - g.t_min) * it / (nt - 1);
    const double u = static_cast<double>(iu) / (nu - 1);
    const double v = nv > 1 ? static_cast<double>(iv) / (nv - 1) : 0.0;
    // Direction in the wedge a ≥ b ≥ c: (1, u, u v) normalised; h its half-width.
    const double ex = 1.0, ey = u, ez = dim == 3 ? u * v : 0.0;
    const double en = std::sqrt(ex * ex + ey * ey + ez * ez);
    const double h = (ex + ey + ez) / (2.0 * en);
    auto eps_at = [&](double R) {
      const double d = R + t * h;
      const double rx = d * ex / en, ry = d * ey / en, rz = d * ez / en;
      return dim == 3 ? exact_fraction_3d(rx, ry, rz, R) : exact_fraction_2d(rx, ry, R);
    };
    const double ea = eps_at(r_fit_a), eb = eps_at(r_fit_b);
    const double e1 = (ea - eb) / (ia - ib);
    const double e0 = ea - e1 * ia;
    tab.values[2 * static_cast<std::size_t>(idx)] = static_cast<float>(e0);
    tab.values[2 * static_cast<std::size_t>(idx) + 1] = static_cast<float>(e1);
  }
  tab.id = g_next_table_id.fetch_add(1);
  return tab;
}

}  // namespace lbdem::imb
