// SubstepGraphs: plain DEM sub-steps replayed as CUDA graphs (substep_graphs.hpp).
#include "substep_graphs.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace lbdem::dem {

SubstepGraphs::SubstepGraphs(const Exec& ex, bool friction, IssueStep issue)
    : ex_(ex), friction_(friction), issue_(issue), queue_key_(kMaxRun), table_(kTable) {
  for (Entry& e : table_) e.key.resize(kMaxRun);
}

void SubstepGraphs::key_words(const State& s, std::uintptr_t* out) {
  auto w = [](const void* p) { return reinterpret_cast<std::uintptr_t>(p); };
  const void* ptr[18] = {s.pos, s.vel, s.omg, s.frc, s.trq, s.frc_old, s.trq_old, s.vpr, s.wpr,
                         s.extf, s.extt, s.x0, s.gid, s.nbr, s.ncount, s.hist, s.whist, s.flags};
  for (int k = 0; k < 18; ++k) out[k] = w(ptr[k]);
  out[18] = static_cast<std::uintptr_t>(s.n);
  out[19] = static_cast<std::uintptr_t>(s.cap);
}

void SubstepGraphs::add(const State& kick, StatusRecord* rec, StatusRecord* next, const State& force) {
  if (len_ == kMaxRun) flush();
  kick_[len_] = kick;
  force_[len_] = force;
  rec_[len_] = rec;
  next_[len_] = next;
  StepKey& k = queue_key_[len_];
  key_words(kick, k.data());
  key_words(force, k.data() + 20);
  k[40] = reinterpret_cast<std::uintptr_t>(rec);
  k[41] = reinterpret_cast<std::uintptr_t>(next);
  ++len_;
}

SubstepGraphs::Entry* SubstepGraphs::find() {
  for (Entry& e : table_)
    if (e.exec && e.len == len_ && std::equal(queue_key_.begin(), queue_key_.begin() + len_, e.key.begin()))
      return &e;
  return nullptr;
}

#if defined(__CUDACC__)

SubstepGraphs::~SubstepGraphs() {
  // Destructor path: nothing to report to (the device may already be gone).
  for (Entry& e : table_)
    if (e.exec) (void)cudaGraphExecDestroy(static_cast<cudaGraphExec_t>(e.exec));
  if (cap_stream_) (void)cudaStreamDestroy(static_cast<cudaStream_t>(cap_stream_));
}

// Records the queued launches into a graph on a private stream (nothing
// runs), then makes `e` its executable: an update of e's graph where the
// shape is the same (cheaper than instantiating), else a new one.
void SubstepGraphs::capture(Entry& e) {
  if (!cap_stream_) {
    cudaStream_t cs = nullptr;
    LBDEM_CUDA_CHECK(cudaStreamCreateWithFlags(&cs, cudaStreamNonBlocking));
    cap_stream_ = cs;
  }
  cudaStream_t cs = static_cast<cudaStream_t>(cap_stream_);
  Exec cex(Backend::Cuda);
  cex.set_stream(cs);
  cex.set_overlap_launches(ex_.overlap_launches());
  LBDEM_CUDA_CHECK(cudaStreamBeginCapture(cs, cudaStreamCaptureModeThreadLocal));
  for (int j = 0; j < len_; ++j) issue_(cex, kick_[j], rec_[j], next_[j], force_[j], friction_);
  cudaGraph_t graph = nullptr;
  LBDEM_CUDA_CHECK(cudaStreamEndCapture(cs, &graph));
  bool updated = false;
  if (e.exec && e.len == len_) {
    cudaGraphExecUpdateResultInfo info{};
    const cudaError_t u = cudaGraphExecUpdate(static_cast<cudaGraphExec_t>(e.exec), graph, &info);
    if (u == cudaSuccess) {
      updated = true;
    } else {
      (void)cudaGetLastError();  // a refused update is not an error: instantiate instead
    }
  }
  if (!updated) {
    if (e.exec) {
      const cudaError_t d = cudaGraphExecDestroy(static_cast<cudaGraphExec_t>(e.exec));
      e.exec = nullptr;
      if (d != cudaSuccess) {
        (void)cudaGraphDestroy(graph);
        LBDEM_CUDA_CHECK(d);
      }
    }
    cudaGraphExec_t exec = nullptr;
    const cudaError_t i = cudaGraphInstantiate(&exec, graph, 0);
    if (i != cudaSuccess) (void)cudaGraphDestroy(graph);
    LBDEM_CUDA_CHECK(i);
    e.exec = exec;
  }
  LBDEM_CUDA_CHECK(cudaGraphDestroy(graph));
  e.len = len_;
  std::copy(queue_key_.begin(), queue_key_.begin() + len_, e.key.begin());
  ++captures;
}

void SubstepGraphs::flush() {
  if (len_ == 0) return;
  Entry* e = find();
  if (!e) {
    // The least recently used entry (an empty one first) takes the new graph.
    e = &table_[0];
    for (Entry& c : table_) {
      if (!c.exec) {
        e = &c;
        break;
      }
      if (c.used < e->used) e = &c;
    }
    capture(*e);
  }
  e->used = ++clock_;
  LBDEM_CUDA_CHECK(cudaGraphLaunch(static_cast<cudaGraphExec_t>(e->exec), ex_.stream()));
  ++graph_launches;
  graph_steps += len_;
  len_ = 0;
}

#else

SubstepGraphs::~SubstepGraphs() = default;
void SubstepGraphs::capture(Entry&) { throw_not_compiled_for_cuda("DEM sub-step graphs"); }
void SubstepGraphs::flush() {
  if (len_ == 0) return;
  throw_not_compiled_for_cuda("DEM sub-step graphs");
}

#endif

}  // namespace lbdem::dem
