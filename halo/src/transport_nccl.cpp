// NCCL transport: ncclSend/ncclRecv on the Exec's stream, one group per
// exchange, on one NCCL communicator per process bootstrapped through MPI
// (rank 0's ncclUniqueId broadcast by Comm). Built only with NCCL (CUDA).
//
// NCCL matches the k-th send from rank a to rank b with the k-th receive
// posted on b from a; it has no tags. Sends are posted in (peer, tag) order
// and receives in (peer, recv_tag) order, so a message's tag on the sender is
// its recv_tag on the receiver and both sides count the same k.
#include <nccl.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>

#include "transport_internal.hpp"

namespace lbdem::halo::detail {
namespace {

[[noreturn]] void throw_nccl_error(ncclResult_t r, const char* call, ncclComm_t comm) {
  std::string msg = std::string("NCCL call failed: ") + call + " -> " + ncclGetErrorString(r);
  const char* last = ncclGetLastError(comm);
  if (last != nullptr && last[0] != '\0') msg += " (" + std::string(last) + ")";
  throw Error(msg);
}
#define LBDEM_NCCL_CHECK(call, comm)                                            \
  do {                                                                          \
    ncclResult_t lbdem_nccl_r_ = (call);                                        \
    if (lbdem_nccl_r_ != ncclSuccess) throw_nccl_error(lbdem_nccl_r_, #call, comm); \
  } while (0)

// The process's NCCL communicator over all ranks of Comm::world(). Made on
// the first NCCL transport (a collective call, like make_transport) and kept:
// making one costs far more than a step. Destroyed at exit, before MPI is
// finalised (it is made after Comm::world(), so it is destroyed before it).
struct NcclWorld {
  ncclComm_t comm = nullptr;
  int device = -1;
  ~NcclWorld() {
    if (comm != nullptr) (void)ncclCommDestroy(comm);
  }
};

ncclComm_t nccl_world(const Comm& comm) {
  int device = -1;
  LBDEM_CUDA_CHECK(cudaGetDevice(&device));
  static NcclWorld world;  // after the CUDA call above: the runtime outlives it
  if (world.comm != nullptr) {
    if (device != world.device)
      throw ResourceError("halo transport nccl: the NCCL communicator was made on GPU " +
                          std::to_string(world.device) + ", but the current GPU is " + std::to_string(device) +
                          " (select the rank's GPU once, before the first transport)");
    return world.comm;
  }
  // NVLink multicast (NVLS) stays off unless the user set it: the machines
  // this runs on must not use it, and halo send/recv gains nothing from it.
  setenv("NCCL_NVLS_ENABLE", "0", 0);
  ncclUniqueId id{};
  if (comm.root()) LBDEM_NCCL_CHECK(ncclGetUniqueId(&id), nullptr);
  std::vector<std::byte> bytes(sizeof id);
  std::memcpy(bytes.data(), &id, sizeof id);
  comm.broadcast(bytes, 0);
  std::memcpy(&id, bytes.data(), sizeof id);
  ncclComm_t c = nullptr;
  LBDEM_NCCL_CHECK(ncclCommInitRank(&c, comm.size(), id, comm.rank()), nullptr);
  world.comm = c;
  world.device = device;
  return c;
}

class NcclTransport final : public Transport {
 public:
  explicit NcclTransport(const Comm& comm) : comm_(comm), nccl_(nccl_world(comm)) {}

  void bind(std::vector<Message> messages) override {
    if (in_flight_) throw Error("halo transport nccl: bind() between start() and finish()");
    validate_messages(messages, comm_, "nccl");
    check_sizes_with_peers(messages, comm_, "nccl");
    self_ = self_copies(messages, comm_);
    times_ = traffic(messages, comm_);
    sends_.clear();
    recvs_.clear();
    for (const Message& m : messages) {
      if (m.peer == comm_.rank()) continue;
      // Empty messages are left out on both sides alike (the sizes agree).
      if (m.send_bytes > 0) sends_.push_back({m.peer, m.tag, m.send, m.send_bytes});
      if (m.recv_bytes > 0) recvs_.push_back({m.peer, m.recv_tag, m.recv, m.recv_bytes});
    }
    const auto order = [](const Part& a, const Part& b) { return a.peer != b.peer ? a.peer < b.peer : a.tag < b.tag; };
    std::sort(sends_.begin(), sends_.end(), order);
    std::sort(recvs_.begin(), recvs_.end(), order);
  }

  void start(const Exec& ex) override {
    const auto t0 = Clock::now();
    if (!ex.on_device()) throw Error("halo transport nccl: start() on the cpu backend; NCCL moves device buffers");
    if (in_flight_) throw Error("halo transport nccl: start() twice without finish()");
    run_self_copies(self_, ex);
    if (!sends_.empty() || !recvs_.empty()) {
      // One group: NCCL runs all sends and receives together, without the
      // ordering deadlocks of separate blocking calls.
      LBDEM_NCCL_CHECK(ncclGroupStart(), nccl_);
      for (const Part& p : sends_)
        LBDEM_NCCL_CHECK(ncclSend(p.buffer, p.bytes, ncclUint8, p.peer, nccl_, ex.stream()), nccl_);
      for (const Part& p : recvs_)
        LBDEM_NCCL_CHECK(ncclRecv(p.buffer, p.bytes, ncclUint8, p.peer, nccl_, ex.stream()), nccl_);
      LBDEM_NCCL_CHECK(ncclGroupEnd(), nccl_);
    }
    in_flight_ = true;
    times_.start = seconds_since(t0);
  }

  void finish(const Exec& ex) override {
    const auto t0 = Clock::now();
    if (!ex.on_device()) throw Error("halo transport nccl: finish() on the cpu backend");
    if (!in_flight_) throw Error("halo transport nccl: finish() without start()");
    in_flight_ = false;
    // The receives complete in stream order: work queued on ex after this
    // sees them. Errors NCCL met in the background (a peer gone, a network
    // fault) are reported here.
    ncclResult_t async = ncclSuccess;
    LBDEM_NCCL_CHECK(ncclCommGetAsyncError(nccl_, &async), nccl_);
    if (async != ncclSuccess) throw_nccl_error(async, "ncclCommGetAsyncError", nccl_);
    times_.finish = seconds_since(t0);
  }

  TransportKind kind() const override { return TransportKind::Nccl; }
  const TransportTimes& times() const override { return times_; }

 private:
  struct Part {
    int peer;
    int tag;
    void* buffer;
    std::size_t bytes;
  };
  const Comm& comm_;
  ncclComm_t nccl_;
  std::vector<SelfCopy> self_;
  std::vector<Part> sends_, recvs_;
  bool in_flight_ = false;
  TransportTimes times_;
};

}  // namespace

std::unique_ptr<Transport> make_nccl_transport(const Comm& comm) { return std::make_unique<NcclTransport>(comm); }

}  // namespace lbdem::halo::detail
