// Conjugate gradients preconditioned by one multigrid V-cycle (cfd/pressure_solver.hpp,
// PressureSolverKind::Multigrid): red-black Gauss-Seidel smoothing, piecewise-constant transfers, the coarse
// end in one kernel of one block and the iterations as CUDA graphs on the device.
#include "cfd/pressure_solver.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#if defined(__CUDACC__)
#include <cub/block/block_reduce.cuh>
#endif

#include "pressure_common.hpp"

namespace lbdem::cfd {
namespace {

// Pair dot products r.z and r.D^-1 r (host path: the same three stages).
struct PairDot1 {
  const double* r; const double* z; const double* diag;
  double* part;
  Index n, parts;
  const double* scal;
  LBDEM_HD void operator()(Index t) const {
    if (scal[slot::kDone] != 0) return;
    double s = 0, q = 0;
    for (Index i = t; i < n; i += parts) {
      s += r[i] * z[i];
      q += r[i] * r[i] / diag[i];
    }
    part[t] = s;
    part[parts + t] = q;
  }
};
struct PairDot2 {
  const double* in;
  double* out;
  Index n, parts;
  const double* scal;
  LBDEM_HD void operator()(Index t) const {
    if (scal[slot::kDone] != 0) return;
    double s = 0, q = 0;
    for (Index i = t; i < n; i += parts) {
      s += in[i];
      q += in[n + i];
    }
    out[t] = s;
    out[parts + t] = q;
  }
};
struct PairDot3 {
  const double* in;
  Index n;
  double* scal;
  CgStage stage;
  double tol2;
  LBDEM_HD void operator()(Index) const {
    if (scal[slot::kDone] != 0) return;
    double s = 0, q = 0;
    for (Index i = 0; i < n; ++i) {
      s += in[i];
      q += in[n + i];
    }
    cg_stage(scal, stage, s, stage == CgStage::Alpha || stage == CgStage::Bnorm ? s : q, tol2);
  }
};

struct MgInit {  // r = b - A x
  const double* b; const double* Ax; double* r;
  LBDEM_HD void operator()(Index i) const { r[i] = b[i] - Ax[i]; }
};
struct Copy {
  const double* from; double* to;
  LBDEM_HD void operator()(Index i) const { to[i] = from[i]; }
};
struct MgStep {  // x += alpha d, r -= alpha Ad
  double* x; double* r; const double* d; const double* Ad; const double* scal;
  LBDEM_HD void operator()(Index i) const {
    if (scal[slot::kDone] != 0) return;
    const double al = scal[slot::kAlpha];
    x[i] += al * d[i];
    r[i] -= al * Ad[i];
  }
};

// The operator's diagonal on one level.
struct LevelDiag {
  LevelView L;
  double* dg;
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    L.coords(ci, c);
    dg[ci] = for_row(L, ci, c, [](double, Index) {});
  }
};

// Coarse face coefficients: thread t over the coarse face boxes of axes 0, 1,
// 2 in turn. Each is the sum of the fine coefficients on the faces it covers,
// over the coarsening factor along its normal (the coarse cells' centres lie
// that much further apart).
struct CoarseFaces {
  LevelView F;   // fine
  int cn[3];     // coarse cells
  int r[3];
  double* out[3];
  Index nf0, nf1;  // coarse face counts of axes 0 and 1
  LBDEM_HD void operator()(Index t) const {
    int a = 0;
    if (t >= nf0) { t -= nf0; a = 1; if (t >= nf1) { t -= nf1; a = 2; } }
    int m[3];
    for (int d = 0; d < 3; ++d) m[d] = cn[d] + (d == a ? 1 : 0);
    int I[3];
    I[0] = static_cast<int>(t % m[0]);
    I[1] = static_cast<int>((t / m[0]) % m[1]);
    I[2] = static_cast<int>(t / (static_cast<Index>(m[0]) * m[1]));
    int lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      if (d == a) {
        lo[d] = r[d] * I[d] < F.n[d] ? r[d] * I[d] : F.n[d];
        hi[d] = lo[d] + 1;
      } else {
        lo[d] = r[d] * I[d];
        hi[d] = lo[d] + r[d] < F.n[d] ? lo[d] + r[d] : F.n[d];
      }
    }
    double s = 0;
    int f[3];
    for (f[2] = lo[2]; f[2] < hi[2]; ++f[2])
      for (f[1] = lo[1]; f[1] < hi[1]; ++f[1])
        for (f[0] = lo[0]; f[0] < hi[0]; ++f[0]) s += F.af[a][F.face(a, f)];
    out[a][static_cast<Index>(I[0]) + static_cast<Index>(m[0]) * (I[1] + static_cast<Index>(m[1]) * I[2])] =
        s / r[a];
  }
};

// A red cell's value in pre-smoothing from a zero guess: b / d (0 where the
// cell has no coupling).
LBDEM_HD inline double pre_red_value(const double* b, const double* dg, Index ci) {
  const double d = dg[ci];
  return d > 0 ? b[ci] / d : 0.0;
}

// Pre-smoothing from a zero guess: red cells x = b / d, then black cells
// x = (b + sum w x_red) / d, the red values formed in place (one launch for
// the red and the black half-sweep).
struct PreSmooth {
  LevelView L;
  const double* dg;
  const double* b;
  double* x;
  const double* scal;
  // False once the solve is done; else cell ci's coordinates into c.
  LBDEM_HD bool active(Index ci, int c[3]) const {
    if (scal[slot::kDone] != 0) return false;
    L.coords(ci, c);
    return true;
  }
  // A black cell's value (b + sum w x_j) / d, red neighbour j's value x_j
  // given by red(j).
  template <class Red>
  LBDEM_HD double black_value(Index ci, const int c[3], Red red) const {
    double acc = b[ci];
    const double d = for_row(L, ci, c, [&](double w, Index j) { acc += w * red(j); });
    return d > 0 ? acc / d : 0.0;
  }
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    if (!active(ci, c)) return;
    if (is_red(c)) {
      x[ci] = pre_red_value(b, dg, ci);
      return;
    }
    const double* bv = b;
    const double* dv = dg;
    x[ci] = black_value(ci, c, [bv, dv](Index j) { return pre_red_value(bv, dv, j); });
  }
};

// Coarse right-hand side: the sum of the fine residuals b - A x over the
// fine cells that a coarse cell covers (restriction = transpose of the
// piecewise-constant prolongation).
struct Restrict {
  LevelView F;
  const double* bf;
  const double* xf;
  int cn[3];
  int r[3];
  double* bc;
  const double* scal;
  // The fine residual b - A x at cell ci (coordinates c).
  LBDEM_HD double residual(Index ci, const int c[3]) const {
    const double* xv = xf;
    double off = 0;
    const double d = for_row(F, ci, c, [&](double w, Index j) { off += w * xv[j]; });
    return bf[ci] - (d * xf[ci] - off);
  }
  // The sum of term(fine cell, its coordinates) over the fine cells that
  // coarse cell t covers, x fastest.
  template <class Term>
  LBDEM_HD double sum_covered(Index t, Term term) const {
    int I[3];
    split3(t, cn[0], cn[1], I);
    int lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      lo[d] = r[d] * I[d];
      hi[d] = lo[d] + r[d] < F.n[d] ? lo[d] + r[d] : F.n[d];
    }
    double sum = 0;
    int c[3];
    for (c[2] = lo[2]; c[2] < hi[2]; ++c[2])
      for (c[1] = lo[1]; c[1] < hi[1]; ++c[1])
        for (c[0] = lo[0]; c[0] < hi[0]; ++c[0]) sum += term(F.cell(c), c);
    return sum;
  }
  LBDEM_HD void operator()(Index t) const {
    if (scal[slot::kDone] != 0) return;
    bc[t] = sum_covered(t, [&](Index ci, const int c[3]) { return residual(ci, c); });
  }
};

// Post-smoothing, black half-sweep, with the coarse correction added to the
// red neighbours it reads (a black cell's new value does not depend on its
// old one, and the red half-sweep after it overwrites the red cells: the
// correction is needed nowhere else).
struct PostBlack {
  LevelView F;
  const double* b;
  double* x;
  const double* e;  // coarse correction
  int cn[3];
  int r[3];
  const double* scal;
  LBDEM_HD void operator()(Index ci) const {
    if (scal[slot::kDone] != 0) return;
    int c[3];
    F.coords(ci, c);
    if (is_red(c)) return;
    double acc = b[ci];
    const double* xv = x;
    const double* ev = e;
    // The coarsening factors are 1 or 2 and the coordinates not negative:
    // o / r is a shift by r - 1 (a division by a runtime divisor is a long
    // sequence on the device, and there are three per neighbour).
    const int s0 = r[0] - 1, s1 = r[1] - 1, s2 = r[2] - 1, c0 = cn[0], c1 = cn[1];
    const double d = for_row_at(F, ci, c, [&](double w, Index j, int o0, int o1, int o2) {
      const Index pc = (o0 >> s0) + static_cast<Index>(c0) * ((o1 >> s1) + static_cast<Index>(c1) * (o2 >> s2));
      acc += w * (xv[j] + ev[pc]);
    });
    x[ci] = d > 0 ? acc / d : 0.0;
  }
};

// Post-smoothing, red half-sweep.
struct PostRed {
  LevelView F;
  const double* b;
  double* x;
  const double* scal;
  LBDEM_HD void operator()(Index ci) const {
    if (scal[slot::kDone] != 0) return;
    int c[3];
    F.coords(ci, c);
    if (!is_red(c)) return;
    double acc = b[ci];
    const double* xv = x;
    const double d = for_row(F, ci, c, [&](double w, Index j) { acc += w * xv[j]; });
    x[ci] = d > 0 ? acc / d : 0.0;
  }
};

// Shorter chains for the device (mg_tail_shared_kernel; Restrict also on the
// levels above the tail): PreSmooth and Restrict each as two stages, so that a thread's
// chain of dependent operations per stage is one cell's row instead of seven
// divisions (PreSmooth's black cells forming their red neighbours' values) or
// eight rows in a row (Restrict's coarse cell summing its fine residuals).
// The same operations on the same values: the same bits.
// Red half of PreSmooth: x = b / d.
struct PreRed {
  PreSmooth p;
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    if (!p.active(ci, c) || !is_red(c)) return;
    p.x[ci] = pre_red_value(p.b, p.dg, ci);
  }
};
// Black half of PreSmooth, reading its red neighbours' values from x (every
// neighbour of a black cell is red: the periodic axes have an even length or
// one cell, whose self-coupling for_row skips).
struct PreBlack {
  PreSmooth p;
  LBDEM_HD void operator()(Index ci) const {
    int c[3];
    if (!p.active(ci, c) || is_red(c)) return;
    const double* xv = p.x;
    p.x[ci] = p.black_value(ci, c, [xv](Index j) { return xv[j]; });
  }
};
// Restrict's fine residuals b - A x, one per fine cell, into r.
struct FineResidual {
  Restrict q;
  double* r;
  LBDEM_HD void operator()(Index ci) const {
    if (q.scal[slot::kDone] != 0) return;
    int c[3];
    q.F.coords(ci, c);
    r[ci] = q.residual(ci, c);
  }
};
// Restrict's sums of those residuals over each coarse cell, in its order.
struct CoarseSum {
  Restrict q;
  const double* r;
  LBDEM_HD void operator()(Index t) const {
    if (q.scal[slot::kDone] != 0) return;
    const double* rv = r;
    q.bc[t] = q.sum_covered(t, [rv](Index ci, const int*) { return rv[ci]; });
  }
};

// The coarsest grid (a few cells): `sweeps` symmetric Gauss-Seidel sweeps
// (forward, then backward) from zero, in one thread.
struct Coarsest {
  LevelView L;
  const double* b;
  double* x;
  int sweeps;
  const double* scal;
  LBDEM_HD void relax(Index ci) const {
    int c[3];
    L.coords(ci, c);
    double acc = b[ci];
    const double* xv = x;
    const double d = for_row(L, ci, c, [&](double w, Index j) { acc += w * xv[j]; });
    x[ci] = d > 0 ? acc / d : 0.0;
  }
  LBDEM_HD void operator()(Index) const {
    if (scal[slot::kDone] != 0) return;
    const Index n = L.cells();
    for (Index i = 0; i < n; ++i) x[i] = 0;
    for (int k = 0; k < sweeps; ++k) {
      for (Index i = 0; i < n; ++i) relax(i);
      for (Index i = n; i-- > 0;) relax(i);
    }
  }
};

// The coarse end of the V-cycle in one kernel of one block: the levels from
// tail_ down (each stage over its cells, a barrier between stages), the
// coarsest grid in thread 0, and back up: on grids of a few thousand cells
// and fewer a block does in a few microseconds what would otherwise be four
// launches per level.
constexpr int kTailMax = 8;
[[maybe_unused]] constexpr int kTailThreads = 512;  // (device code only)
constexpr Index kTailCells = 1024;
struct TailArgs {
  int count;  // levels smoothed here before the coarsest grid
  Index cells[kTailMax], ccells[kTailMax];
  PreSmooth pre[kTailMax];
  Restrict res[kTailMax];
  PostBlack pb[kTailMax];
  PostRed pr[kTailMax];
  Coarsest co;
};
static_assert(sizeof(TailArgs) <= 4000, "kernel parameters beyond 4 KB");

// Shared-memory doubles of one tail level: its three face arrays, diagonal,
// right-hand side and iterate (the same layout on the host, which sizes the
// launch, and in the kernel, which lays the arrays out).
LBDEM_HD inline Index tail_level_doubles(const LevelView& L) {
  Index n = 3 * L.cells();
  for (int a = 0; a < 3; ++a) n += static_cast<Index>(L.fext(a, 0)) * L.fext(a, 1) * L.fext(a, 2);
  return n;
}

#if defined(__CUDACC__)
// The same stages on copies in shared memory: every stage of the tail is a
// chain of dependent loads over a few thousand cells in one block, so their
// latency, not their bandwidth, sets its time. The face arrays and diagonals
// of every tail level and the top level's right-hand side are loaded once,
// the coarser right-hand sides and all iterates live only here, and the top
// level's iterate (the coarse correction the levels above read) is written
// back at the end. The stages are those of mg_tail_kernel with PreSmooth and
// Restrict each split in two (PreRed, PreBlack; FineResidual into a shared
// scratch of the first tail level's size, CoarseSum): the same bits.
__global__ void __launch_bounds__(kTailThreads) mg_tail_shared_kernel(const TailArgs a) {
  extern __shared__ double sm[];
  if (a.co.scal[slot::kDone] != 0) return;
  const Index t0 = threadIdx.x, dt = blockDim.x;
  // Level k's arrays: af[3], dg, b, x (k = a.count: the coarsest grid).
  struct Arrays {
    double* af[3];
    double *dg, *b, *x;
  };
  auto arrays = [&](int k) {
    Arrays r{};
    double* p = sm;
    for (int j = 0; j <= k; ++j) {
      const LevelView L = j < a.count ? a.pre[j].L : a.co.L;
      for (int ax = 0; ax < 3; ++ax) {
        r.af[ax] = p;
        p += static_cast<Index>(L.fext(ax, 0)) * L.fext(ax, 1) * L.fext(ax, 2);
      }
      r.dg = p;
      r.b = p + L.cells();
      r.x = p + 2 * L.cells();
      p += 3 * L.cells();
    }
    return r;
  };
  for (int k = 0; k <= a.count; ++k) {
    const LevelView L = k < a.count ? a.pre[k].L : a.co.L;
    const Arrays s = arrays(k);
    for (int ax = 0; ax < 3; ++ax) {
      const Index nf = static_cast<Index>(L.fext(ax, 0)) * L.fext(ax, 1) * L.fext(ax, 2);
      for (Index i = t0; i < nf; i += dt) s.af[ax][i] = L.af[ax][i];
    }
    if (k < a.count)
      for (Index i = t0; i < a.cells[k]; i += dt) s.dg[i] = a.pre[k].dg[i];
  }
  {
    const Arrays s = arrays(0);
    const Index n = a.count > 0 ? a.cells[0] : a.co.L.cells();
    const double* b = a.count > 0 ? a.pre[0].b : a.co.b;
    for (Index i = t0; i < n; i += dt) s.b[i] = b[i];
  }
  __syncthreads();
  auto view = [&](LevelView L, const Arrays& s) {
    for (int ax = 0; ax < 3; ++ax) L.af[ax] = s.af[ax];
    return L;
  };
  // The fine residuals of Restrict: after the coarsest grid's arrays.
  double* const rs = arrays(a.count).x + a.co.L.cells();
  for (int k = 0; k < a.count; ++k) {
    const Arrays s = arrays(k), c = arrays(k + 1);
    PreSmooth pre = a.pre[k];
    pre.L = view(pre.L, s);
    pre.dg = s.dg;
    pre.b = s.b;
    pre.x = s.x;
    for (Index i = t0; i < a.cells[k]; i += dt) PreRed{pre}(i);
    __syncthreads();
    for (Index i = t0; i < a.cells[k]; i += dt) PreBlack{pre}(i);
    __syncthreads();
    Restrict res = a.res[k];
    res.F = view(res.F, s);
    res.bf = s.b;
    res.xf = s.x;
    res.bc = c.b;
    for (Index i = t0; i < a.cells[k]; i += dt) FineResidual{res, rs}(i);
    __syncthreads();
    for (Index i = t0; i < a.ccells[k]; i += dt) CoarseSum{res, rs}(i);
    __syncthreads();
  }
  if (t0 == 0) {
    const Arrays s = arrays(a.count);
    Coarsest co = a.co;
    co.L = view(co.L, s);
    co.b = s.b;
    co.x = s.x;
    co(0);
  }
  __syncthreads();
  for (int k = a.count - 1; k >= 0; --k) {
    const Arrays s = arrays(k), c = arrays(k + 1);
    PostBlack pb = a.pb[k];
    pb.F = view(pb.F, s);
    pb.b = s.b;
    pb.x = s.x;
    pb.e = c.x;
    for (Index i = t0; i < a.cells[k]; i += dt) pb(i);
    __syncthreads();
    PostRed pr = a.pr[k];
    pr.F = view(pr.F, s);
    pr.b = s.b;
    pr.x = s.x;
    for (Index i = t0; i < a.cells[k]; i += dt) pr(i);
    __syncthreads();
  }
  const Arrays s = arrays(0);
  const Index n = a.count > 0 ? a.cells[0] : a.co.L.cells();
  double* x = a.count > 0 ? a.pre[0].x : a.co.x;
  for (Index i = t0; i < n; i += dt) x[i] = s.x[i];
}

__global__ void __launch_bounds__(kTailThreads) mg_tail_kernel(const TailArgs a) {
  if (a.co.scal[slot::kDone] != 0) return;
  const Index t0 = threadIdx.x, dt = blockDim.x;
  for (int k = 0; k < a.count; ++k) {
    for (Index i = t0; i < a.cells[k]; i += dt) a.pre[k](i);
    __syncthreads();
    for (Index i = t0; i < a.ccells[k]; i += dt) a.res[k](i);
    __syncthreads();
  }
  if (t0 == 0) a.co(0);
  __syncthreads();
  for (int k = a.count - 1; k >= 0; --k) {
    for (Index i = t0; i < a.cells[k]; i += dt) a.pb[k](i);
    __syncthreads();
    for (Index i = t0; i < a.cells[k]; i += dt) a.pr[k](i);
    __syncthreads();
  }
}
#endif

#if defined(__CUDACC__)
// One-launch dot products on the device: each block sums a fixed strided
// share (cub::BlockReduce, deterministic), the last block to finish (a
// ticket) adds the block sums in block order and runs the scalar step.
constexpr int kDotBlock = 256;
constexpr int kDotMaxBlocks = 256;

__global__ void __launch_bounds__(kDotBlock) pair_dot_kernel(Index n, const double* x, const double* y,
                                                              const double* diag, double* part,
                                                              unsigned int* ticket, double* scal, CgStage stage,
                                                              double tol2) {
  if (scal[slot::kDone] != 0) return;
  using BR = cub::BlockReduce<double, kDotBlock>;
  __shared__ typename BR::TempStorage tmp;
  __shared__ bool last;
  double s = 0, q = 0;
  const Index stride = static_cast<Index>(gridDim.x) * kDotBlock;
  for (Index i = static_cast<Index>(blockIdx.x) * kDotBlock + threadIdx.x; i < n; i += stride) {
    s += x[i] * y[i];
    if (diag) q += x[i] * x[i] / diag[i];
  }
  const double bs = BR(tmp).Sum(s);
  __syncthreads();
  const double bq = BR(tmp).Sum(q);
  if (threadIdx.x == 0) {
    part[blockIdx.x] = bs;
    part[kDotMaxBlocks + blockIdx.x] = bq;
    __threadfence();
    last = atomicAdd(ticket, 1u) == gridDim.x - 1;
  }
  __syncthreads();
  if (!last) return;
  __threadfence();
  const unsigned t = threadIdx.x;
  const double ps = t < gridDim.x ? __ldcg(part + t) : 0.0;
  const double pq = t < gridDim.x ? __ldcg(part + kDotMaxBlocks + t) : 0.0;
  __syncthreads();
  const double S = BR(tmp).Sum(ps);
  __syncthreads();
  const double Q = BR(tmp).Sum(pq);
  if (t == 0) {
    cg_stage(scal, stage, S, diag ? Q : S, tol2);
    *ticket = 0;
  }
}
#endif

Index face_count(const GasGridView& g, int a) {
  Index n = 1;
  for (int d = 0; d < 3; ++d) n *= g.n[d] + (d == a ? 1 : 0);
  return n;
}

}  // namespace

// The coarse levels of the V-cycle and the one-launch dot product's ticket (the constructor, multigrid only).
void PressureSolver::init_multigrid() {
  const Backend b = ex_.backend();
  const Index nc = g_.cells();
  const GasGridView& g = g_;
  const auto sizes = multigrid_levels(g, std::max(1, p_.coarsest_cells));
  dg0_ = Buffer<double>(b, nc);
  for (std::size_t l = 1; l < sizes.size(); ++l) {
    Level L;
    L.g = g;
    for (int a = 0; a < 3; ++a) {
      L.g.n[a] = sizes[l][static_cast<std::size_t>(a)];
      L.r[a] = sizes[l - 1][static_cast<std::size_t>(a)] == L.g.n[a] ? 1 : 2;
    }
    const Index n = L.g.cells();
    for (int a = 0; a < 3; ++a) L.af[a] = Buffer<double>(b, face_count(L.g, a));
    L.dg = Buffer<double>(b, n);
    L.b = Buffer<double>(b, n);
    L.x = Buffer<double>(b, n);
    lv_.push_back(std::move(L));
  }
  ticket_ = Buffer<unsigned int>(b, 1);
  ticket_.fill_zero(ex_);  // on the solver's queue, as d_ and scal_ (pressure_solver.cu)
  if (ex_.on_device() && p_.graphs) rs_ = Buffer<double>(b, nc);
  // The first level small enough for one block, at most kTailMax above the
  // coarsest. LBDEM_PRESSURE_TAIL_CELLS replaces the size limit (A/B timing:
  // the kernels and their order, hence the bits, are the same for any limit).
  const int nl = static_cast<int>(lv_.size());
  Index tail_cells = kTailCells;
  if (const char* tc = std::getenv("LBDEM_PRESSURE_TAIL_CELLS")) {
    char* end = nullptr;
    tail_cells = std::strtol(tc, &end, 10);
    if (end == tc || *end != '\0' || tail_cells < 0)
      throw ConfigError(std::string("LBDEM_PRESSURE_TAIL_CELLS: '") + tc + "' is not a cell count (0 or more)");
  }
  tail_ = nl;
  for (int l = nl - 1; l >= 0 && nl - l <= kTailMax; --l) {
    const Index c = l == 0 ? nc : lv_[static_cast<std::size_t>(l - 1)].g.cells();
    if (c > tail_cells) break;
    tail_ = l;
  }
  // The tail in shared memory where its levels fit in a block's (the
  // device's opt-in limit); else it reads them where they are.
  tail_shared_bytes_ = 0;
#if defined(__CUDACC__)
  const char* env = std::getenv("LBDEM_PRESSURE_TAIL_SHARED");
  if (ex_.on_device() && tail_ < nl && !(env && std::strcmp(env, "0") == 0)) {
    Index doubles = 0;
    for (int l = tail_; l <= nl; ++l) {
      const GasGridView& lg = l == 0 ? g : lv_[static_cast<std::size_t>(l - 1)].g;
      const double* none[3] = {nullptr, nullptr, nullptr};
      doubles += tail_level_doubles(level_view(lg, none));
    }
    // Restrict's fine residuals (the largest fine level is the tail's first).
    doubles += tail_ == 0 ? nc : lv_[static_cast<std::size_t>(tail_ - 1)].g.cells();
    int dev = 0, optin = 0;
    LBDEM_CUDA_CHECK(cudaGetDevice(&dev));
    LBDEM_CUDA_CHECK(cudaDeviceGetAttribute(&optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev));
    const Index bytes = doubles * static_cast<Index>(sizeof(double));
    if (bytes <= optin) {
      LBDEM_CUDA_CHECK(cudaFuncSetAttribute(mg_tail_shared_kernel, cudaFuncAttributeMaxDynamicSharedMemorySize,
                                            static_cast<int>(bytes)));
      tail_shared_bytes_ = static_cast<int>(bytes);
    }
  }
#endif
}

void PressureSolver::setup_mg(const Exec& ex, const double* const af[3]) {
  LevelView F = level_view(g_, af);
  for_each(ex, g_.cells(), LevelDiag{F, dg0_.data()});
  for (Level& L : lv_) {
    CoarseFaces cf{};
    cf.F = F;
    for (int a = 0; a < 3; ++a) {
      cf.cn[a] = L.g.n[a];
      cf.r[a] = L.r[a];
      cf.out[a] = L.af[a].data();
    }
    cf.nf0 = L.af[0].size();
    cf.nf1 = L.af[1].size();
    for_each(ex, L.af[0].size() + L.af[1].size() + L.af[2].size(), cf);
    const double* caf[3] = {L.af[0].data(), L.af[1].data(), L.af[2].data()};
    F = level_view(L.g, caf);
    for_each(ex, L.g.cells(), LevelDiag{F, L.dg.data()});
  }
}

// z = V(b): one V-cycle from a zero guess. Level l's kernels: PreSmooth,
// Restrict (down), PostBlack, PostRed (up); the coarsest grid's in between.
// On the device, with launch savings on, the levels from tail_ down run in
// one kernel of one block (the same functors in the same order).
void PressureSolver::vcycle(const Exec& ex, const double* const af[3], const double* b, double* x) {
  const double* s = scal_.data();
  const int nl = static_cast<int>(lv_.size());
  auto view = [&](int l) {
    if (l == 0) return level_view(g_, af);
    const Level& L = lv_[static_cast<std::size_t>(l - 1)];
    const double* caf[3] = {L.af[0].data(), L.af[1].data(), L.af[2].data()};
    return level_view(L.g, caf);
  };
  auto bb = [&](int l) -> const double* { return l == 0 ? b : lv_[static_cast<std::size_t>(l - 1)].b.data(); };
  auto xx = [&](int l) -> double* { return l == 0 ? x : lv_[static_cast<std::size_t>(l - 1)].x.data(); };
  auto dg = [&](int l) -> const double* { return l == 0 ? dg0_.data() : lv_[static_cast<std::size_t>(l - 1)].dg.data(); };
  auto pre = [&](int l) { return PreSmooth{view(l), dg(l), bb(l), xx(l), s}; };
  auto restrict_ = [&](int l) {
    const Level& C = lv_[static_cast<std::size_t>(l)];
    return Restrict{view(l), bb(l), xx(l), {C.g.n[0], C.g.n[1], C.g.n[2]}, {C.r[0], C.r[1], C.r[2]}, C.b.data(), s};
  };
  auto post_black = [&](int l) {
    const Level& C = lv_[static_cast<std::size_t>(l)];
    return PostBlack{view(l), bb(l), xx(l), C.x.data(), {C.g.n[0], C.g.n[1], C.g.n[2]}, {C.r[0], C.r[1], C.r[2]}, s};
  };
  auto post_red = [&](int l) { return PostRed{view(l), bb(l), xx(l), s}; };
  const Coarsest coarsest{view(nl), bb(nl), xx(nl), std::max(1, p_.coarse_sweeps), s};
  auto cells = [&](int l) { return l == 0 ? g_.cells() : lv_[static_cast<std::size_t>(l - 1)].g.cells(); };
  const int top = ex.on_device() && p_.graphs ? tail_ : nl;
  const bool split = ex.on_device() && p_.graphs;
  for (int l = 0; l < top; ++l) {
    for_each(ex, cells(l), pre(l));
    if (split) {
      for_each(ex, cells(l), FineResidual{restrict_(l), rs_.data()});
      for_each(ex, cells(l + 1), CoarseSum{restrict_(l), rs_.data()});
    } else {
      for_each(ex, cells(l + 1), restrict_(l));
    }
  }
  if (ex.on_device() && p_.graphs) {
#if defined(__CUDACC__)
    TailArgs t{};
    t.count = nl - top;
    for (int k = 0; k < t.count; ++k) {
      t.cells[k] = cells(top + k);
      t.ccells[k] = cells(top + k + 1);
      t.pre[k] = pre(top + k);
      t.res[k] = restrict_(top + k);
      t.pb[k] = post_black(top + k);
      t.pr[k] = post_red(top + k);
    }
    t.co = coarsest;
    if (tail_shared_bytes_ > 0)
      mg_tail_shared_kernel<<<1, kTailThreads, tail_shared_bytes_, ex.stream()>>>(t);
    else
      mg_tail_kernel<<<1, kTailThreads, 0, ex.stream()>>>(t);
    LBDEM_CUDA_CHECK(cudaGetLastError());
#else
    for_each(ex, 1, coarsest);  // not reached: a device Exec needs the CUDA build
#endif
  } else {
    for_each(ex, 1, coarsest);
  }
  for (int l = top - 1; l >= 0; --l) {
    for_each(ex, cells(l), post_black(l));
    for_each(ex, cells(l), post_red(l));
  }
}

// Dot product of u and w into the scalar step; with diag also u.D^-1 u.
void PressureSolver::dot(const Exec& ex, const double* u, const double* w, const double* diag, int stage) {
  const Index n = g_.cells();
  double* s = scal_.data();
  const double tol2 = p_.tolerance * p_.tolerance;
  const CgStage st = static_cast<CgStage>(stage);
  if (ex.on_device()) {
#if defined(__CUDACC__)
    const int blocks =
        static_cast<int>(std::max<Index>(1, std::min<Index>(kDotMaxBlocks, (n + kDotBlock - 1) / kDotBlock)));
    pair_dot_kernel<<<blocks, kDotBlock, 0, ex.stream()>>>(n, u, w, diag, part1_.data(), ticket_.data(), s, st, tol2);
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
#endif
  }
  const double* dd = diag ? diag : diag_.data();
  for_each(ex, parts1_, PairDot1{u, w, dd, part1_.data(), n, parts1_, s});
  for_each(ex, parts2_, PairDot2{part1_.data(), part2_.data(), parts1_, parts2_, s});
  for_each(ex, 1, PairDot3{part2_.data(), parts2_, s, st, tol2});
}

// `count` multigrid-PCG iterations (kernels only: a CUDA graph can hold them).
void PressureSolver::iterate_mg(const Exec& ex, const double* const af[3], double* x, int count) {
  const LevelView L = level_view(g_, af);
  const Index n = g_.cells();
  double* s = scal_.data();
  for (int k = 0; k < count; ++k) {
    for_each(ex, n, ApplyA{L, d_.data(), Ad_.data(), s});
    dot(ex, d_.data(), Ad_.data(), nullptr, static_cast<int>(CgStage::Alpha));
    for_each(ex, n, MgStep{x, r_.data(), d_.data(), Ad_.data(), s});
    vcycle(ex, af, r_.data(), z_.data());
    dot(ex, r_.data(), z_.data(), diag_.data(), static_cast<int>(CgStage::Update));
    for_each(ex, n, CgDir{d_.data(), z_.data(), s});
  }
}

// The set-up of the coarse levels and the start of PCG: r = b - A x (warm
// start), z = V r, d = z (kernels only: a CUDA graph can hold them).
void PressureSolver::start_mg(const Exec& ex, const double* const af[3], const double* b, double* x) {
  const LevelView L = level_view(g_, af);
  const Index n = g_.cells();
  double* s = scal_.data();
  for_each(ex, n, JacobiDiag{L, diag_.data()});
  setup_mg(ex, af);
  for_each(ex, 1, ZeroDone{s});
  for_each(ex, n, Scale{b, diag_.data(), z_.data()});
  dot(ex, b, z_.data(), nullptr, static_cast<int>(CgStage::Bnorm));
  for_each(ex, n, ApplyA{L, x, Ad_.data(), s});
  for_each(ex, n, MgInit{b, Ad_.data(), r_.data()});
  vcycle(ex, af, r_.data(), z_.data());
  dot(ex, r_.data(), z_.data(), diag_.data(), static_cast<int>(CgStage::Init));
  for_each(ex, n, Copy{z_.data(), d_.data()});
}

void PressureSolver::solve_mg(const double* const af[3], const double* b, double* x) {
  // On the device with launch savings: the start as one CUDA graph, the
  // iterations in chunks of poll_every as another; with the device loop that
  // graph repeats its chunk on the device until keep_iterating() says stop
  // (no host read); else the host asks first after the last solve's count,
  // then every poll_every iterations.
  const bool dev = ex_.on_device();
  const bool fused = dev && p_.graphs;
  const int chunk = fused ? std::max(1, p_.poll_every) : 1;
  if (fused)
    run_graph(0, af, b, x, 0);
  else
    start_mg(ex_, af, b, x);
  if (device_loop_) {
    run_graph(2, af, b, x, chunk);
    return;
  }
  double flags[2] = {0, 0};  // done, iterations
  int it = 0;
  int next_poll = dev ? std::max(1, expected_iterations_) : 1;
  while (it < p_.max_iterations) {
    if (fused)
      run_graph(1, af, b, x, chunk);
    else
      iterate_mg(ex_, af, x, 1);
    it += chunk;
    if (it >= next_poll || it >= p_.max_iterations) {
      ex_.synchronize();  // the copy below is ordered after the legacy stream only
      scal_.copy_to_host(flags, 2, slot::kDone);
      if (!keep_iterating(flags[0], flags[1], p_.max_iterations)) break;
      next_poll = it + (dev ? std::max(1, p_.poll_every) : 1);
    }
  }
  expected_iterations_ = static_cast<int>(flags[1]);
}

#if defined(__CUDACC__)
// The device loop's test after each chunk: run the body again while the
// solve goes on (cudaGraphSetConditional sets the WHILE node's condition).
__global__ void mg_while_kernel(cudaGraphConditionalHandle h, const double* scal, int max_iterations) {
  cudaGraphSetConditional(h, keep_iterating(scal[slot::kDone], scal[slot::kIterations], max_iterations) ? 1u : 0u);
}

// Graph k (0: start_mg, 1: `chunk` iterations, 2: `chunk` iterations and the
// test, repeated by a WHILE node whose condition starts at 1 on every launch),
// captured on first use or when the pointers it was made with change, then
// launched on the solver's stream.
void PressureSolver::run_graph(int k, const double* const af[3], const double* b, double* x, int chunk) {
  const void* key[5] = {af[0], af[1], af[2], k == 0 ? static_cast<const void*>(b) : static_cast<const void*>(x),
                        k == 0 ? static_cast<const void*>(x)
                               : reinterpret_cast<const void*>(static_cast<std::intptr_t>(chunk))};
  if (!graph_exec_[k] || !std::equal(key, key + 5, graph_key_[k])) {
    if (graph_exec_[k]) LBDEM_CUDA_CHECK(cudaGraphExecDestroy(static_cast<cudaGraphExec_t>(graph_exec_[k])));
    graph_exec_[k] = nullptr;
    if (!cap_stream_) {
      cudaStream_t cs = nullptr;
      LBDEM_CUDA_CHECK(cudaStreamCreateWithFlags(&cs, cudaStreamNonBlocking));
      cap_stream_ = cs;
    }
    cudaStream_t cs = static_cast<cudaStream_t>(cap_stream_);
    Exec cex(Backend::Cuda);
    cex.set_stream(cs);
    cex.set_overlap_launches(ex_.overlap_launches());
    cudaGraph_t graph = nullptr;
    if (k == 2) {
      LBDEM_CUDA_CHECK(cudaGraphCreate(&graph, 0));
      cudaGraphConditionalHandle h{};
      cudaGraphNodeParams np{};
      cudaGraphNode_t node = nullptr;
      cudaError_t e = cudaGraphConditionalHandleCreate(&h, graph, 1, cudaGraphCondAssignDefault);
      if (e == cudaSuccess) {
        np.type = cudaGraphNodeTypeConditional;
        np.conditional.handle = h;
        np.conditional.type = cudaGraphCondTypeWhile;
        np.conditional.size = 1;
        e = cudaGraphAddNode(&node, graph, nullptr, nullptr, 0, &np);
      }
      if (e == cudaSuccess)
        e = cudaStreamBeginCaptureToGraph(cs, np.conditional.phGraph_out[0], nullptr, nullptr, 0,
                                          cudaStreamCaptureModeThreadLocal);
      if (e != cudaSuccess) {
        (void)cudaGraphDestroy(graph);
        LBDEM_CUDA_CHECK(e);
      }
      iterate_mg(cex, af, x, chunk);
      mg_while_kernel<<<1, 1, 0, cs>>>(h, scal_.data(), p_.max_iterations);
      LBDEM_CUDA_CHECK(cudaGetLastError());
      cudaGraph_t body = nullptr;
      e = cudaStreamEndCapture(cs, &body);  // the body graph, owned by the conditional node
      if (e != cudaSuccess) (void)cudaGraphDestroy(graph);
      LBDEM_CUDA_CHECK(e);
    } else {
      LBDEM_CUDA_CHECK(cudaStreamBeginCapture(cs, cudaStreamCaptureModeThreadLocal));
      if (k == 0)
        start_mg(cex, af, b, x);
      else
        iterate_mg(cex, af, x, chunk);
      LBDEM_CUDA_CHECK(cudaStreamEndCapture(cs, &graph));
    }
    cudaGraphExec_t exec = nullptr;
    const cudaError_t e = cudaGraphInstantiate(&exec, graph, 0);
    LBDEM_CUDA_CHECK(cudaGraphDestroy(graph));
    LBDEM_CUDA_CHECK(e);
    graph_exec_[k] = exec;
    std::copy(key, key + 5, graph_key_[k]);
  }
  LBDEM_CUDA_CHECK(cudaGraphLaunch(static_cast<cudaGraphExec_t>(graph_exec_[k]), ex_.stream()));
}
void PressureSolver::release_graph() noexcept {
  // Destructor path: nothing to report to (the device may already be gone).
  for (void*& g : graph_exec_) {
    if (g) (void)cudaGraphExecDestroy(static_cast<cudaGraphExec_t>(g));
    g = nullptr;
  }
  if (cap_stream_) (void)cudaStreamDestroy(static_cast<cudaStream_t>(cap_stream_));
  cap_stream_ = nullptr;
}
#else
void PressureSolver::run_graph(int, const double* const*, const double*, double*, int) {
  throw_not_compiled_for_cuda("PressureSolver graphs");
}
void PressureSolver::release_graph() noexcept {}
#endif

}  // namespace lbdem::cfd
