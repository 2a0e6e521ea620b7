// Void-fraction deposition kernels (cfd/void_fraction.hpp).
#include "cfd/void_fraction.hpp"

namespace lbdem::cfd {
namespace {

// One particle: its volume over the cell volume, in quanta, spread by the
// stencil weights.
struct DepositVolume {
  GasGridView g;
  Deposition scheme;
  const dem::Real4* pos_r;
  unsigned long long* acc;
  double scale;  // 1 / (V_c quantum)
  LBDEM_HD void operator()(Index i) const {
    const dem::Real4 p = pos_r[i];
    const double vp = 4.0 / 3.0 * 3.14159265358979323846 * p.w * p.w * p.w;
    const Stencil3D s = stencil_3d(g, scheme, dem::xyz(p));
    deposit_fixed(g, s, vp * scale, acc);
  }
};

struct FixedToDouble {
  const unsigned long long* acc;
  double* out;
  LBDEM_HD void operator()(Index c) const { out[c] = static_cast<double>(static_cast<long long>(acc[c])) * kFixedQuantum; }
};

}  // namespace

VoidFraction::VoidFraction(const Exec& ex, const GasGridView& g, Deposition scheme)
    : ex_(ex), g_(g), scheme_(scheme), acc_(ex.backend(), g.cells()), solid_(ex.backend(), g.cells()) {
  // On the Exec's queue: deposit() there (a second queue, lagged forces)
  // does not wait for memsets on the legacy default stream.
  acc_.fill_zero(ex_);
  solid_.fill_zero(ex_);
}

void VoidFraction::deposit(const dem::ParticleView& p) {
  acc_.fill_zero(ex_);
  for_each(ex_, p.n, DepositVolume{g_, scheme_, p.pos_r, acc_.data(), kFixedScale / g_.volume()});
  for_each(ex_, g_.cells(), FixedToDouble{acc_.data(), solid_.data()});
}

}  // namespace lbdem::cfd
