#pragma once
// What the pressure solvers (pressure_solver.cu, pressure_pcg.cu, pressure_multigrid.cu) share: the operator's
// rows on a grid level, the named scalar slots and the scalar step after a dot product, and the kernels both
// preconditioned CG variants launch. Internal to cfd/src. Everything here is in an unnamed namespace: each
// translation unit instantiates its own kernels from it.
#include <cstdint>

#include "cfd/pressure_solver.hpp"

namespace lbdem::cfd {
namespace {

// The solver's scalars on the device (scal_): one slot each. The kernels read `done` first and do nothing once
// it is set, so iterations queued after convergence cost a launch and no work.
namespace slot {
enum : int {
  kRz = 0,          // r.z of the current iterate
  kBnorm = 1,       // |b|_D^2, the scale of the stopping test
  kDad = 2,         // d.A d
  kAlpha = 3,       // step length r.z / d.A d
  kBeta = 4,        // new r.z / old r.z
  kDone = 5,        // 1 once converged (or nothing left to do)
  kIterations = 6,  // iterations taken
  kResidual = 7,    // |r|_D^2 / |b|_D^2
  kCount = 8
};
}  // namespace slot
static_assert(slot::kIterations == slot::kDone + 1, "solve_mg reads done and iterations in one copy");

// One grid level as the kernels see it: the cells, the face coefficients
// (face boxes as the gas solver's), and periodic axes.
// Cell index t -> (i, j, k) on a grid of n0 x n1 x ... cells. Indices below
// 2^32 (every gas grid) divide in 32-bit unsigned arithmetic: a 64-bit
// division is a long emulated sequence on the device, and the smoothers and
// transfers split indices several times per cell. The same integers either way.
LBDEM_HD inline void split3(Index t, int n0, int n1, int c[3]) {
  if (t >= 0 && t <= static_cast<Index>(0xffffffffu)) {
    const unsigned u = static_cast<unsigned>(t), a = static_cast<unsigned>(n0), b = static_cast<unsigned>(n1);
    const unsigned r = u / a;
    c[0] = static_cast<int>(u - r * a);
    const unsigned k = r / b;
    c[1] = static_cast<int>(r - k * b);
    c[2] = static_cast<int>(k);
    return;
  }
  c[0] = static_cast<int>(t % n0);
  const Index r = t / n0;
  c[1] = static_cast<int>(r % n1);
  c[2] = static_cast<int>(r / n1);
}

struct LevelView {
  int n[3];
  bool per[3];
  const double* af[3];

  LBDEM_HD Index cells() const { return static_cast<Index>(n[0]) * n[1] * n[2]; }
  LBDEM_HD Index cell(const int c[3]) const { return c[0] + static_cast<Index>(n[0]) * (c[1] + static_cast<Index>(n[1]) * c[2]); }
  LBDEM_HD void coords(Index ci, int c[3]) const { split3(ci, n[0], n[1], c); }
  LBDEM_HD int fext(int a, int d) const { return n[d] + (d == a ? 1 : 0); }
  LBDEM_HD Index face(int a, const int f[3]) const {
    return f[0] + static_cast<Index>(fext(a, 0)) * (f[1] + static_cast<Index>(fext(a, 1)) * f[2]);
  }
  // Face of axis a above cell c (the periodic axis's last face is face 0).
  LBDEM_HD Index hi_face(int a, const int c[3]) const {
    int f[3] = {c[0], c[1], c[2]};
    f[a] += 1;
    if (per[a] && f[a] == n[a]) f[a] = 0;
    return face(a, f);
  }
};

inline LevelView level_view(const GasGridView& g, const double* const af[3]) {
  LevelView v{};
  for (int a = 0; a < 3; ++a) {
    v.n[a] = g.n[a];
    v.per[a] = g.periodic[a];
    v.af[a] = af[a];
  }
  return v;
}

LBDEM_HD inline int wrap(int i, int n) { return i < 0 ? i + n : (i >= n ? i - n : i); }

// Row ci of the operator: returns the diagonal (every face but those that
// join the cell to itself across a periodic axis of one cell, whose terms
// cancel) and calls f(w, j) for each off-diagonal coupling -w to cell j
// (unrolled: no per-thread arrays). for_row_at: the same, f(w, j, o0, o1, o2)
// also given cell j's coordinates.
template <class F>
LBDEM_HD LBDEM_FORCEINLINE double for_row_at(const LevelView& L, Index ci, const int c[3], F&& f) {
  double d = 0;
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int a = 0; a < 3; ++a) {
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (int side = 0; side < 2; ++side) {
      const double w = side == 0 ? L.af[a][L.face(a, c)] : L.af[a][L.hi_face(a, c)];
      int o[3] = {c[0], c[1], c[2]};
      o[a] += side == 0 ? -1 : 1;
      if (o[a] < 0 || o[a] >= L.n[a]) {
        if (!L.per[a]) {  // boundary face: Dirichlet (outlet) or nothing (w = 0)
          d += w;
          continue;
        }
        o[a] = wrap(o[a], L.n[a]);
      }
      const Index oj = L.cell(o);
      if (oj == ci) continue;
      d += w;
      f(w, oj, o[0], o[1], o[2]);
    }
  }
  return d;
}

template <class F>
LBDEM_HD LBDEM_FORCEINLINE double for_row(const LevelView& L, Index ci, const int c[3], F&& f) {
  return for_row_at(L, ci, c, [&](double w, Index j, int, int, int) { f(w, j); });
}

// Red cells: (i + j + k) even. With every periodic axis of even length (or of
// one cell) the neighbours of a cell all have the other colour.
LBDEM_HD inline bool is_red(const int c[3]) { return ((c[0] + c[1] + c[2]) & 1) == 0; }

// ---------------------------------------------------------------- kernels of both variants

// Jacobi diagonal: the sum of the cell's face coefficients (1 where all are 0).
struct JacobiDiag {
  LevelView L;
  double* diag;
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    L.coords(ci, c);
    double dg = 0;
    for (int a = 0; a < 3; ++a) dg += L.af[a][L.face(a, c)] + L.af[a][L.hi_face(a, c)];
    diag[ci] = dg > 0 ? dg : 1.0;
  }
};

// y = A x (skipped once the solve has converged).
struct ApplyA {
  LevelView L;
  const double* x;
  double* y;
  const double* scal;
  LBDEM_HD void operator()(Index ci) const {
    if (scal && scal[slot::kDone] != 0) return;
    int c[3];
    L.coords(ci, c);
    const double xc = x[ci];
    double s = 0;
    for (int a = 0; a < 3; ++a) {
      const double al = L.af[a][L.face(a, c)], ah = L.af[a][L.hi_face(a, c)];
      int o[3] = {c[0], c[1], c[2]};
      o[a] = c[a] - 1;
      double xl = 0, xh = 0;
      if (o[a] >= 0 || L.per[a]) { o[a] = wrap(o[a], L.n[a]); xl = x[L.cell(o)]; }
      o[a] = c[a] + 1;
      if (o[a] < L.n[a] || L.per[a]) { o[a] = wrap(o[a], L.n[a]); xh = x[L.cell(o)]; }
      s += al * (xc - xl) + ah * (xc - xh);
    }
    y[ci] = s;
  }
};

enum class CgStage { Bnorm, Init, Alpha, Update };

// The scalar step after a dot product: s = r.z, and (multigrid) rr = r.D^-1 r,
// the convergence measure (for Jacobi CG rr = s).
LBDEM_HD inline void cg_stage(double* scal, CgStage stage, double s, double rr, double tol2) {
  switch (stage) {
    case CgStage::Bnorm: scal[slot::kBnorm] = s; scal[slot::kIterations] = 0; break;
    case CgStage::Init:
      scal[slot::kRz] = s;
      scal[slot::kResidual] = scal[slot::kBnorm] > 0 ? rr / scal[slot::kBnorm] : rr;
      if (rr <= tol2 * scal[slot::kBnorm] || rr == 0 || s == 0) scal[slot::kDone] = 1;
      break;
    case CgStage::Alpha: scal[slot::kDad] = s; scal[slot::kAlpha] = s != 0 ? scal[slot::kRz] / s : 0; break;
    case CgStage::Update:
      scal[slot::kBeta] = scal[slot::kRz] != 0 ? s / scal[slot::kRz] : 0;
      scal[slot::kRz] = s;
      scal[slot::kIterations] += 1;
      scal[slot::kResidual] = scal[slot::kBnorm] > 0 ? rr / scal[slot::kBnorm] : rr;
      if (rr <= tol2 * scal[slot::kBnorm] || rr == 0 || s == 0) scal[slot::kDone] = 1;
      break;
  }
}

struct CgDir {  // d = z + beta d
  double* d; const double* z; const double* scal;
  LBDEM_HD void operator()(Index i) const {
    if (scal[slot::kDone] != 0) return;
    d[i] = z[i] + scal[slot::kBeta] * d[i];
  }
};
struct Scale {  // z = b / diag (for |b|_D)
  const double* b; const double* diag; double* z;
  LBDEM_HD void operator()(Index i) const { z[i] = b[i] / diag[i]; }
};
struct ZeroDone {
  double* scal;
  LBDEM_HD void operator()(Index) const { scal[slot::kDone] = 0; }
};

}  // namespace
}  // namespace lbdem::cfd
