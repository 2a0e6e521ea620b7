// Whole-field gas measures by device reductions (cfd/gas_monitor.hpp).
#include "cfd/gas_monitor.hpp"

#include <cmath>

#include "core/algorithms.hpp"

namespace lbdem::cfd {
namespace {

// Faces of axis a: (n_a + 1) x the other two extents, x fastest.
struct FaceBox {
  int m[3];
  LBDEM_HD Index size() const { return static_cast<Index>(m[0]) * m[1] * m[2]; }
};
FaceBox face_box(const GasGridView& g, int a) {
  FaceBox b{{g.n[0], g.n[1], g.n[2]}};
  b.m[a] += 1;
  return b;
}

struct FaceCourant {  // |u| dt / h; a non-finite value counts in FaceNonFinite instead
  const double* u;
  double scale;
  LBDEM_HD double operator()(Index f) const {
    const double c = (u[f] < 0 ? -u[f] : u[f]) * scale;
    return c == c ? c : 0.0;
  }
};

struct NonFinite {
  const double* x;
  // x - x is 0 for a finite x, NaN for an infinite or NaN one.
  LBDEM_HD double operator()(Index i) const { return x[i] - x[i] == 0.0 ? 0.0 : 1.0; }
};

// Net gas volume flux into the domain through the boundary faces a cell
// touches (the flux eps u A as the solver's continuity takes it: the
// adjacent cell's gas fraction at a boundary face); `sign` +1 sums the
// inflows, -1 the outflows.
struct BoundaryFlux {
  GasGridView g;
  const double* u[3];
  const double* eps;
  FaceBox fb[3];
  double sign;
  LBDEM_HD double operator()(Index ci) const {
    int c[3];
    g.coords(ci, c[0], c[1], c[2]);
    const double area = g.h * g.h;
    double s = 0;
    for (int a = 0; a < 3; ++a) {
      if (g.periodic[a]) continue;
      for (int side = 0; side < 2; ++side) {
        if (c[a] != (side == 0 ? 0 : g.n[a] - 1)) continue;
        int f[3] = {c[0], c[1], c[2]};
        if (side == 1) f[a] += 1;
        const Index fi = f[0] + static_cast<Index>(fb[a].m[0]) * (f[1] + static_cast<Index>(fb[a].m[1]) * f[2]);
        const double inward = (side == 0 ? 1.0 : -1.0) * u[a][fi] * eps[ci] * area;
        const double q = sign * inward;
        s += q > 0 ? q : 0.0;
      }
    }
    return s;
  }
};

struct Storage {
  const double* eps;
  const double* eps_old;
  double scale;  // V_c / dt
  LBDEM_HD double operator()(Index c) const { return (eps[c] - eps_old[c]) * scale; }
};

struct LayerMean {  // pressure of layer k along z, over the layer's cell count
  const double* p;
  Index layer_cells, first;
  LBDEM_HD double operator()(Index i) const { return p[first + i] / static_cast<double>(layer_cells); }
};

}  // namespace

GasMonitor::GasMonitor(const Exec& ex) : ex_(ex), scratch_(std::make_unique<Scratch>()) {}
GasMonitor::~GasMonitor() = default;

GasMeasures GasMonitor::measure(const GasSolver& gas) {
  const GasGridView& g = gas.grid();
  const GasParams& p = gas.params();
  Scratch& s = *scratch_;
  GasMeasures m;
  const Index nc = g.cells();
  const double* u[3];
  FaceBox fb[3];
  for (int a = 0; a < 3; ++a) {
    u[a] = gas.face_velocity(a).data();
    fb[a] = face_box(g, a);
    const Index nf = fb[a].size();
    const double c = transform_reduce(ex_, nf, 0.0, MaxOp{}, FaceCourant{u[a], p.dt / g.h}, s);
    m.max_courant = c > m.max_courant ? c : m.max_courant;
    m.nonfinite += transform_reduce(ex_, nf, 0.0, SumOp{}, NonFinite{u[a]}, s);
  }
  m.nonfinite += transform_reduce(ex_, nc, 0.0, SumOp{}, NonFinite{gas.pressure().data()}, s);
  m.nonfinite += transform_reduce(ex_, nc, 0.0, SumOp{}, NonFinite{gas.gas_fraction().data()}, s);
  const double* eps = gas.gas_fraction().data();
  BoundaryFlux bf{g, {u[0], u[1], u[2]}, eps, {fb[0], fb[1], fb[2]}, 1.0};
  m.inflow = transform_reduce(ex_, nc, 0.0, SumOp{}, bf, s);
  bf.sign = -1.0;
  m.outflow = transform_reduce(ex_, nc, 0.0, SumOp{}, bf, s);
  m.storage = transform_reduce(ex_, nc, 0.0, SumOp{},
                               Storage{eps, gas.gas_fraction_old().data(), g.volume() / p.dt}, s);
  const Index layer = static_cast<Index>(g.n[0]) * g.n[1];
  m.p_bottom = transform_reduce(ex_, layer, 0.0, SumOp{}, LayerMean{gas.pressure().data(), layer, 0}, s);
  m.p_top = transform_reduce(ex_, layer, 0.0, SumOp{},
                             LayerMean{gas.pressure().data(), layer, layer * (g.n[2] - 1)}, s);
  return m;
}

}  // namespace lbdem::cfd
