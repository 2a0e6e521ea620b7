// A probe of compute-sanitizer on kernels inside a CUDA graph WHILE node (the
// pressure solve's device loop, cfd/src/pressure_multigrid.cu): a block
// reduction kernel shaped like pair_dot_kernel (cub::BlockReduce, early return
// on a device flag, last-block ticket) and an update kernel, looped by a WHILE
// node or launched one by one. A tool that reports errors for the WHILE form
// and none for the same kernels launched one by one reports on itself, not on
// the kernels (scripts/sanitize_gpu.sh, SANITIZE_WHILE).
//   nvcc -std=c++17 -arch=sm_90 -o probe scripts/sanitizer_while_probe.cu
//   compute-sanitizer --tool TOOL ./probe ITERATIONS REPEATS MODE
// MODE: w (WHILE node), p (one by one), o (WHILE node, the update kernel
// reading one element past its array: memcheck must report it there);
// further letters add a kernel shaped like one of the pressure solve's tail
// kernel's traits to every iteration (in the WHILE body or the plain loop):
// b a parameter block of ~3.9 KB (TailArgs), s 96 KB of dynamic shared memory
// (the opt-in tail), l a large per-thread local array (a deep call stack).
// PROBE_STACK=BYTES sets the device's per-thread stack limit first.
// Prints the iteration count and the sum (the same for w and p).
#include <cub/block/block_reduce.cuh>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#define CK(x) do { cudaError_t e_ = (x); if (e_ != cudaSuccess) { std::printf("%s: %s\n", #x, cudaGetErrorString(e_)); std::exit(1);} } while (0)
constexpr int B = 256;
__global__ void __launch_bounds__(B) dot(long n, const double* x, double* part, unsigned* ticket, double* scal) {
  if (scal[1] != 0) return;
  using BR = cub::BlockReduce<double, B>;
  __shared__ typename BR::TempStorage tmp;
  __shared__ bool last;
  double s = 0;
  for (long i = blockIdx.x * (long)B + threadIdx.x; i < n; i += (long)gridDim.x * B) s += x[i] * x[i];
  const double bs = BR(tmp).Sum(s);
  __syncthreads();
  const double bq = BR(tmp).Sum(s * 2);
  if (threadIdx.x == 0) { part[blockIdx.x] = bs + bq; __threadfence(); last = atomicAdd(ticket, 1u) == gridDim.x - 1; }
  __syncthreads();
  if (!last) return;
  __threadfence();
  const double ps = threadIdx.x < gridDim.x ? __ldcg(part + threadIdx.x) : 0.0;
  __syncthreads();
  const double S = BR(tmp).Sum(ps);
  __syncthreads();
  const double Q = BR(tmp).Sum(ps * 0.5);
  if (threadIdx.x == 0) { scal[0] += S + Q; scal[2] += 1; if (scal[2] >= scal[3]) scal[1] = 1; *ticket = 0; }
}
__global__ void axpy(long n, double* x, const double* scal, int past_end) {
  if (scal[1] != 0) return;
  long i = blockIdx.x * (long)blockDim.x + threadIdx.x;
  if (i < n) x[i] = 0.999 * x[i] + 1e-3 + (i == n - 1 && past_end ? 0 * x[i + past_end] : 0.0);
}
struct Big { double v[480]; int n; };  // ~3.85 KB of kernel parameters
__global__ void big(const Big a, double* x, const double* scal) {
  if (scal[1] != 0) return;
  if (threadIdx.x < a.n) x[threadIdx.x] += 1e-9 * a.v[threadIdx.x % 480];
}
__global__ void shm(double* x, long n, const double* scal) {
  extern __shared__ double sh[];
  if (scal[1] != 0) return;
  const int m = 96 * 1024 / 8;
  for (int i = threadIdx.x; i < m; i += blockDim.x) sh[i] = x[i % n];
  __syncthreads();
  double s = 0;
  for (int i = threadIdx.x; i < m; i += blockDim.x) s += sh[(i * 7) % m];
  __syncthreads();
  if (threadIdx.x == 0) x[0] = 0.5 * x[0] + 1e-12 * s;
}
__global__ void loc(double* x, long n, const double* scal, int k) {
  if (scal[1] != 0) return;
  double a[256];
  for (int i = 0; i < 256; ++i) a[i] = x[(threadIdx.x + i) % n];
  double s = 0;
  for (int i = 0; i < 256; ++i) s += a[(i * k + threadIdx.x) & 255];
  if (threadIdx.x == 0 && blockIdx.x == 0) x[1] = 0.5 * x[1] + 1e-12 * s;
}
__global__ void cond(cudaGraphConditionalHandle h, const double* scal) { cudaGraphSetConditional(h, scal[1] == 0 ? 1u : 0u); }
int main(int argc, char** argv) {
  const long n = 11000;
  double *x, *part, *scal; unsigned* ticket; const int iters = argc > 1 ? std::atoi(argv[1]) : 200; const int reps = argc > 2 ? std::atoi(argv[2]) : 20;
  const bool use_while = !(argc > 3 && argv[3][0] == 'p');
  const int past_end = argc > 3 && argv[3][0] == 'o' ? 1 : 0;
  const char* extra = argc > 3 ? argv[3] + 1 : "";
  const bool with_big = std::strchr(extra, 'b'), with_shm = std::strchr(extra, 's'), with_loc = std::strchr(extra, 'l');
  Big bg{}; bg.n = 64; for (int i = 0; i < 480; ++i) bg.v[i] = i;
  // PROBE_STACK=BYTES: the per-thread stack the device reserves (cudaLimitStackSize), to test whether a tool's
  // larger instrumented frames outgrow what a graph's conditional body was given.
  if (const char* st = std::getenv("PROBE_STACK")) CK(cudaDeviceSetLimit(cudaLimitStackSize, std::strtoul(st, nullptr, 10)));
  if (with_shm) CK(cudaFuncSetAttribute(shm, cudaFuncAttributeMaxDynamicSharedMemorySize, 96 * 1024));
  // The extra kernels of one iteration (before the update and the reduction).
  auto extras = [&](cudaStream_t s_) {
    if (with_big) big<<<1, 64, 0, s_>>>(bg, x, scal);
    if (with_shm) shm<<<1, 512, 96 * 1024, s_>>>(x, n, scal);
    if (with_loc) loc<<<4, 128, 0, s_>>>(x, n, scal, 13);
  };
  CK(cudaMalloc(&x, n * 8)); CK(cudaMalloc(&part, 512 * 8)); CK(cudaMalloc(&scal, 8 * 8)); CK(cudaMalloc(&ticket, 4));
  CK(cudaMemset(x, 0, n * 8)); CK(cudaMemset(part, 0, 512 * 8)); CK(cudaMemset(ticket, 0, 4));
  cudaStream_t st; CK(cudaStreamCreate(&st));
  const int blocks = (n + B - 1) / B;
  cudaGraphExec_t exec = nullptr;
  cudaGraphConditionalHandle h{};
  if (use_while) {
    cudaGraph_t g; CK(cudaGraphCreate(&g, 0));
    CK(cudaGraphConditionalHandleCreate(&h, g, 1, cudaGraphCondAssignDefault));
    cudaGraphNodeParams np{}; np.type = cudaGraphNodeTypeConditional; np.conditional.handle = h;
    np.conditional.type = cudaGraphCondTypeWhile; np.conditional.size = 1;
    cudaGraphNode_t node; CK(cudaGraphAddNode(&node, g, nullptr, nullptr, 0, &np));
    cudaGraph_t body = np.conditional.phGraph_out[0];
    CK(cudaStreamBeginCaptureToGraph(st, body, nullptr, nullptr, 0, cudaStreamCaptureModeRelaxed));
    for (int k = 0; k < 2; ++k) { extras(st); axpy<<<blocks, B, 0, st>>>(n, x, scal, past_end); dot<<<blocks, B, 0, st>>>(n, x, part, ticket, scal); }
    cond<<<1, 1, 0, st>>>(h, scal);
    CK(cudaStreamEndCapture(st, &body));
    CK(cudaGraphInstantiate(&exec, g, 0));
  }
  double hs[8];
  for (int r = 0; r < reps; ++r) {
    double init[8] = {0, 0, 0, double(iters), 0, 0, 0, 0};
    CK(cudaMemcpyAsync(scal, init, 64, cudaMemcpyHostToDevice, st));
    if (use_while) CK(cudaGraphLaunch(exec, st));
    else for (int k = 0; k < iters; ++k) { extras(st); axpy<<<blocks, B, 0, st>>>(n, x, scal, past_end); dot<<<blocks, B, 0, st>>>(n, x, part, ticket, scal); CK(cudaGetLastError()); }
    CK(cudaMemcpyAsync(hs, scal, 64, cudaMemcpyDeviceToHost, st));
    CK(cudaStreamSynchronize(st));
  }
  std::printf("%s: count %.0f sum %.17g\n", use_while ? "while" : "plain", hs[2], hs[0]);
  return 0;
}
