// The wall gap correction of the coupled step (imb/wall_lubrication.hpp): one
// thread per particle, each adding its own force (no atomics, no allocation).
#include "imb/wall_lubrication.hpp"

namespace lbdem::imb {

namespace {
struct AddWallLubrication {
  WallLubricationParams k;
  SphereView p;
  double* force;
  int fstride;
  LBDEM_HD void operator()(Index i) const {
    const Index s = i * p.stride;
    const double x[3] = {p.x[s], p.y[s], p.z ? p.z[s] : 0.0};
    const double v[3] = {p.vx[s], p.vy[s], p.vz ? p.vz[s] : 0.0};
    double f[3] = {0, 0, 0};
    wall_lubrication_add(k, x, p.r[s], v, f);
    double* o = force + i * fstride;
    o[0] += f[0];
    o[1] += f[1];
    o[2] += f[2];
  }
};
}  // namespace

void add_wall_lubrication(const Exec& ex, const WallLubricationParams& k, const SphereView& p, Index n,
                          double* force, int fstride) {
  if (n <= 0 || k.count == 0 || force == nullptr || p.vx == nullptr || p.vy == nullptr) return;
  for_each(ex, n, AddWallLubrication{k, p, force, fstride});
}

}  // namespace lbdem::imb
