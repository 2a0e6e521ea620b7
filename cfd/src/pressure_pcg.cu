// Jacobi-preconditioned conjugate gradients (cfd/pressure_solver.hpp, PressureSolverKind::Cg): every scalar
// on the device, dot products in three deterministic launches, the host polling `done` every poll_every
// iterations.
#include "cfd/pressure_solver.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "pressure_common.hpp"

namespace lbdem::cfd {
namespace {

// Deterministic device-side dot products: strided partial sums, then fewer,
// then one thread; the result goes into a scalar slot.
struct Dot1 {
  const double* x;
  const double* y;
  double* part;
  Index n, parts;
  const double* scal;
  LBDEM_HD void operator()(Index t) const {
    if (scal[slot::kDone] != 0) return;
    double s = 0;
    for (Index i = t; i < n; i += parts) s += x[i] * y[i];
    part[t] = s;
  }
};
struct Dot2 {
  const double* in;
  double* out;
  Index n, parts;
  const double* scal;
  LBDEM_HD void operator()(Index t) const {
    if (scal[slot::kDone] != 0) return;
    double s = 0;
    for (Index i = t; i < n; i += parts) s += in[i];
    out[t] = s;
  }
};

struct Dot3 {
  const double* in;
  Index n;
  double* scal;
  CgStage stage;
  double tol2;
  LBDEM_HD void operator()(Index) const {
    if (scal[slot::kDone] != 0) return;
    double s = 0;
    for (Index i = 0; i < n; ++i) s += in[i];
    cg_stage(scal, stage, s, s, tol2);
  }
};

struct CgInit {  // r = b - A x, z = r / diag, d = z
  const double* b; const double* Ax; const double* diag;
  double* r; double* z; double* d;
  LBDEM_HD void operator()(Index i) const {
    r[i] = b[i] - Ax[i];
    z[i] = r[i] / diag[i];
    d[i] = z[i];
  }
};
struct CgStep {  // x += alpha d, r -= alpha Ad, z = r / diag
  double* x; double* r; double* z; const double* d; const double* Ad; const double* diag; const double* scal;
  LBDEM_HD void operator()(Index i) const {
    if (scal[slot::kDone] != 0) return;
    const double al = scal[slot::kAlpha];
    x[i] += al * d[i];
    r[i] -= al * Ad[i];
    z[i] = r[i] / diag[i];
  }
};
}  // namespace

void PressureSolver::solve_cg(const double* const af[3], const double* b, double* x) {
  const LevelView L = level_view(g_, af);
  const Index n = g_.cells();
  double* s = scal_.data();
  const double tol2 = p_.tolerance * p_.tolerance;
  auto dot = [&](const double* u, const double* w, CgStage stage) {
    for_each(ex_, parts1_, Dot1{u, w, part1_.data(), n, parts1_, s});
    for_each(ex_, parts2_, Dot2{part1_.data(), part2_.data(), parts1_, parts2_, s});
    for_each(ex_, 1, Dot3{part2_.data(), parts2_, s, stage, tol2});
  };
  for_each(ex_, 1, ZeroDone{s});
  // |b|_D^2, then r = b - A x (warm start from the last pressure).
  for_each(ex_, n, Scale{b, diag_.data(), z_.data()});
  dot(b, z_.data(), CgStage::Bnorm);
  for_each(ex_, n, ApplyA{L, x, Ad_.data(), s});
  for_each(ex_, n, CgInit{b, Ad_.data(), diag_.data(), r_.data(), z_.data(), d_.data()});
  dot(r_.data(), z_.data(), CgStage::Init);
  double done = 0;
  for (int it = 0; it < p_.max_iterations; ++it) {
    for_each(ex_, n, ApplyA{L, d_.data(), Ad_.data(), s});
    dot(d_.data(), Ad_.data(), CgStage::Alpha);
    for_each(ex_, n, CgStep{x, r_.data(), z_.data(), d_.data(), Ad_.data(), diag_.data(), s});
    dot(r_.data(), z_.data(), CgStage::Update);
    for_each(ex_, n, CgDir{d_.data(), z_.data(), s});
    const int poll = ex_.on_device() ? p_.poll_every : 1;
    if ((it + 1) % poll == 0) {
      ex_.synchronize();  // the copy below is ordered after the legacy stream only
      scal_.copy_to_host(&done, 1, slot::kDone);
      if (done != 0) break;
    }
  }
}

}  // namespace lbdem::cfd
