// A coupled snapshot's fields packed on the device and copied to page-locked
// host memory in one transfer (imb/snapshot_pack.hpp).
#include "imb/snapshot_pack.hpp"

#include <cstdlib>
#include <string>

#include "core/buffer.hpp"
#include "core/error.hpp"
#include "core/half.hpp"
#include "imb/coupled.hpp"
#include "lbm/dispatch.hpp"
#include "lbm/kernels.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

namespace {

// Density and velocity of one cell of the owned box into the pack, in the
// output type O. The cell's values come from lbm::MacroKernel itself (run on
// a box of that one cell into registers), so they are the foreground path's
// doubles bit for bit; O = float rounds each once, as the writer does.
template <class L, class T, lbm::StreamKind S, int P, class O>
struct PackFluidKernel {
  lbm::MacroKernel<L, T, S, P> macro;  // src, grid, flags and force set; box and outputs per cell
  CellBox box;                         // the owned box
  O* rho;                              // box.size() values
  O* u;                                // 3 box.size() values
  LBDEM_HD void operator()(Index cell, int x, int y, int z) const {
    double r = 0, v[3] = {0, 0, 0};
    lbm::MacroKernel<L, T, S, P> one = macro;
    one.box.lo[0] = x;
    one.box.lo[1] = y;
    one.box.lo[2] = z;
    one.box.ext[0] = one.box.ext[1] = one.box.ext[2] = 1;
    one.rho = &r;
    one.u = v;
    one(cell, x, y, z);
    const Index o = (x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]));
    rho[o] = static_cast<O>(r);
    for (int a = 0; a < 3; ++a) u[3 * o + a] = static_cast<O>(v[a]);
  }
};

// out[i] = in[i] rounded to float. The solid fraction is made in double
// (in) and stored as float (out); the two ranges do not overlap.
struct ToFloat {
  const double* in;
  float* out;
  LBDEM_HD void operator()(Index i) const { out[i] = static_cast<float>(in[i]); }
};

template <class L, class T, class O>
void pack_fluid(const Exec& ex, lbm::StreamKind streaming, const lbm::LbmRaw& raw, const CellBox& box, O* rho,
                O* u) {
  lbm::dispatch_parity(streaming, raw.step, [&](auto S, auto P) {
    PackFluidKernel<L, T, decltype(S)::value, decltype(P)::value, O> k{};
    k.macro.src = lbm::PopView<T>{static_cast<T*>(raw.src), raw.stride};
    k.macro.g = raw.grid;
    k.macro.flags = raw.has_boundaries ? raw.flags : nullptr;
    for (int a = 0; a < 3; ++a) k.macro.F[a] = raw.body_force[static_cast<std::size_t>(a)];
    k.box = box;
    k.rho = rho;
    k.u = u;
    for_each_cell(ex, raw.grid, box, k);
  });
}

template <class O>
void pack_fluid_any(lbm::LbmSolver& fluid, const CellBox& box, O* rho, O* u) {
  const lbm::LbmSetup& s = fluid.setup();
  const lbm::LbmRaw raw = fluid.raw();
  const Exec& ex = fluid.exec(lbm::Lane::Main);
  const bool d2 = s.lattice == lbm::LatticeKind::D2Q9;
  switch (s.precision) {
    case lbm::Precision::FP32:
      d2 ? pack_fluid<lbm::D2Q9, float>(ex, s.streaming, raw, box, rho, u) : pack_fluid<lbm::D3Q19, float>(ex, s.streaming, raw, box, rho, u);
      break;
    case lbm::Precision::FP64:
      d2 ? pack_fluid<lbm::D2Q9, double>(ex, s.streaming, raw, box, rho, u) : pack_fluid<lbm::D3Q19, double>(ex, s.streaming, raw, box, rho, u);
      break;
    case lbm::Precision::FP16S:
      d2 ? pack_fluid<lbm::D2Q9, Fp16s>(ex, s.streaming, raw, box, rho, u) : pack_fluid<lbm::D3Q19, Fp16s>(ex, s.streaming, raw, box, rho, u);
      break;
    case lbm::Precision::FP16C:
      d2 ? pack_fluid<lbm::D2Q9, Fp16c>(ex, s.streaming, raw, box, rho, u) : pack_fluid<lbm::D3Q19, Fp16c>(ex, s.streaming, raw, box, rho, u);
      break;
  }
}

std::size_t value_bytes(bool fp32) { return fp32 ? sizeof(float) : sizeof(double); }

}  // namespace

std::size_t SnapshotPack::device_bytes(Backend b, Index cells, bool fp32) {
  return b == Backend::Cuda ? host_bytes(cells, fp32) : 0;
}

std::size_t SnapshotPack::host_bytes(Index cells, bool fp32) {
  return 5 * static_cast<std::size_t>(cells > 0 ? cells : 0) * value_bytes(fp32);
}

SnapshotPack::SnapshotPack(Backend b, Index cells, bool fp32) : backend_(b), cells_(cells), fp32_(fp32) {
  const std::size_t bytes = host_bytes(cells, fp32);
  if (bytes == 0) return;
  if (b == Backend::Cuda) {
#if defined(LBDEM_HAVE_CUDA)
    device_ = backend_alloc(b, bytes);
    const cudaError_t e = cudaHostAlloc(&host_, bytes, cudaHostAllocDefault);
    if (e != cudaSuccess) {
      backend_free(b, device_);
      device_ = nullptr;
      host_ = nullptr;
      throw ResourceError("output.background: cannot reserve " + std::to_string(bytes) +
                          " bytes of page-locked host memory for the snapshot of this rank's piece (" +
                          cudaGetErrorString(e) + "); set output.background: false");
    }
    return;
#else
    throw_not_compiled_for_cuda("SnapshotPack");
#endif
  }
  host_ = backend_alloc(Backend::Host, bytes);
}

SnapshotPack::~SnapshotPack() {
  if (device_) backend_free(backend_, device_);
  if (!host_) return;
#if defined(LBDEM_HAVE_CUDA)
  if (backend_ == Backend::Cuda) {
    (void)cudaFreeHost(host_);  // from a destructor: no throw
    return;
  }
#endif
  backend_free(Backend::Host, host_);
}

MemoryUse SnapshotPack::memory_use() const {
  MemoryUse m;
  if (device_) m.add("snapshot pack (output.background)", host_bytes(cells_, fp32_));
  return m;
}

void SnapshotPack::take(lbm::LbmSolver& fluid, CoupledSolver& cs) {
  const CellBox own = fluid.setup().domain.owned();
  if (own.size() != cells_)
    throw Error("SnapshotPack::take: the owned box has " + std::to_string(own.size()) + " cells, the pack " +
                std::to_string(cells_));
  if (cells_ == 0) return;
  const auto M = static_cast<std::size_t>(cells_);
  void* at = device_ ? device_ : host_;
  // The run's queue: the fluid's main queue, which the coupling's kernels
  // share; the pack follows the last step's work there.
  const Exec& ex = fluid.exec(lbm::Lane::Main);
  if (fp32_) {
    float* f = static_cast<float*>(at);
    // The solid fraction in double first, in the first 8M bytes (the density
    // and velocity slots, written after), then rounded into its own slots
    // [4M, 5M): no second buffer.
    auto* eps = static_cast<double*>(at);
    cs.solid_fraction_device(own, eps);
    for_each(ex, cells_, ToFloat{eps, f + 4 * M});
    pack_fluid_any<float>(fluid, own, f, f + M);
  } else {
    double* d = static_cast<double*>(at);
    cs.solid_fraction_device(own, d + 4 * M);
    pack_fluid_any<double>(fluid, own, d, d + M);
  }
  if (device_) {
#if defined(LBDEM_HAVE_CUDA)
    LBDEM_CUDA_CHECK(cudaMemcpyAsync(host_, device_, host_bytes(cells_, fp32_), cudaMemcpyDeviceToHost, ex.stream()));
    LBDEM_CUDA_CHECK(cudaStreamSynchronize(ex.stream()));
#endif
    return;
  }
  ex.synchronize();
}

}  // namespace lbdem::imb
