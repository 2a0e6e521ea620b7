// MPI point-to-point transports: HostMpi and DeviceMpi.
//
// HostMpi on the host backend hands the module's buffers to MPI directly. On
// the CUDA backend it stages through pinned host memory allocated in bind():
// start() queues the device-to-host copies on the Exec's stream after the
// packing kernels, waits for them, then posts the receives and sends;
// finish() waits for MPI and queues the host-to-device copies, so the
// unpacking kernels queued next on the stream see the data.
// DeviceMpi hands the device buffers to a CUDA-aware MPI; start() waits for
// the stream first, because MPI reads the buffers outside of it.
#include <algorithm>
#include <cstddef>

#include "transport_internal.hpp"

namespace lbdem::halo::detail {

#if defined(LBDEM_HAVE_MPI)
namespace {

class MpiTransport final : public Transport {
 public:
  MpiTransport(const Comm& comm, Backend backend, bool staged)
      : comm_(comm), backend_(backend), staged_(staged && backend == Backend::Cuda) {
    if (comm_.native() != nullptr) {
      // Its own communicator: the tags of two transports in flight at once
      // (populations, forces, particles) never meet.
      LBDEM_MPI_CHECK(MPI_Comm_dup(mpi_comm(comm_), &mpi_));
      LBDEM_MPI_CHECK(MPI_Comm_set_errhandler(mpi_, MPI_ERRORS_RETURN));
    }
  }
  ~MpiTransport() override {
    free_staging();
    int finalised = 1;
    MPI_Finalized(&finalised);
    if (!finalised && mpi_ != MPI_COMM_NULL) MPI_Comm_free(&mpi_);
  }

  void bind(std::vector<Message> messages) override {
    if (in_flight_) throw Error(std::string("halo transport ") + name() + ": bind() between start() and finish()");
    validate_messages(messages, comm_, name());
    check_sizes_with_peers(messages, comm_, name());
    self_ = self_copies(messages, comm_);
    const TransportTimes t = traffic(messages, comm_);
    times_ = TransportTimes{};
    times_.bytes_sent = t.bytes_sent;
    times_.messages = t.messages;

    free_staging();
    sends_.clear();
    recvs_.clear();
    for (const Message& m : messages) {
      if (m.peer == comm_.rank()) continue;
      if (m.send_bytes > 0) sends_.push_back({m.peer, m.tag, m.send, m.send_bytes, nullptr});
      if (m.recv_bytes > 0) recvs_.push_back({m.peer, m.recv_tag, m.recv, m.recv_bytes, nullptr});
    }
    if (staged_) {
      stage(sends_, send_stage_);
      stage(recvs_, recv_stage_);
    }
    requests_.assign(sends_.size() + recvs_.size(), MPI_REQUEST_NULL);
  }

  void start(const Exec& ex) override {
    const auto t0 = Clock::now();
    check_exec(ex, "start");
    if (in_flight_) throw Error(std::string("halo transport ") + name() + ": start() twice without finish()");
    run_self_copies(self_, ex);
#if defined(LBDEM_HAVE_CUDA)
    if (staged_)
      for (const Part& s : sends_)
        LBDEM_CUDA_CHECK(cudaMemcpyAsync(s.host, s.buffer, s.bytes, cudaMemcpyDeviceToHost, ex.stream()));
    // The packing kernels (and, staged, the copies above) must be done before
    // MPI reads; and the previous finish()'s copies out of the receive
    // staging must be done before MPI writes into it again.
    if (ex.on_device() && (!sends_.empty() || !recvs_.empty())) LBDEM_CUDA_CHECK(cudaStreamSynchronize(ex.stream()));
#endif
    std::size_t r = 0;
    for (const Part& p : recvs_)
      LBDEM_MPI_CHECK(MPI_Irecv(target(p), static_cast<int>(p.bytes), MPI_BYTE, p.peer, p.tag, mpi_, &requests_[r++]));
    for (const Part& p : sends_)
      LBDEM_MPI_CHECK(MPI_Isend(target(p), static_cast<int>(p.bytes), MPI_BYTE, p.peer, p.tag, mpi_, &requests_[r++]));
    in_flight_ = true;
    times_.start = seconds_since(t0);
  }

  void finish(const Exec& ex) override {
    const auto t0 = Clock::now();
    check_exec(ex, "finish");
    if (!in_flight_) throw Error(std::string("halo transport ") + name() + ": finish() without start()");
    in_flight_ = false;
    if (!requests_.empty())
      LBDEM_MPI_CHECK(MPI_Waitall(static_cast<int>(requests_.size()), requests_.data(), MPI_STATUSES_IGNORE));
#if defined(LBDEM_HAVE_CUDA)
    if (staged_)
      for (const Part& p : recvs_)
        LBDEM_CUDA_CHECK(cudaMemcpyAsync(p.buffer, p.host, p.bytes, cudaMemcpyHostToDevice, ex.stream()));
#endif
    times_.finish = seconds_since(t0);
  }

  TransportKind kind() const override {
    return backend_ == Backend::Cuda && !staged_ ? TransportKind::DeviceMpi : TransportKind::HostMpi;
  }
  const TransportTimes& times() const override { return times_; }

 private:
  // One direction of one message: the module's buffer and, staged, its
  // pinned host copy.
  struct Part {
    int peer;
    int tag;
    void* buffer;
    std::size_t bytes;
    void* host;
  };

  const char* name() const { return to_string(kind()); }
  void* target(const Part& p) const { return staged_ ? p.host : p.buffer; }

  void check_exec(const Exec& ex, const char* call) const {
    if (ex.backend() != backend_)
      throw Error(std::string("halo transport ") + name() + ": " + call + "() on the " + to_string(ex.backend()) +
                  " backend, but bound for the " + to_string(backend_) + " backend");
  }

  // One pinned block for all parts, each part at a 256-byte boundary.
  void stage([[maybe_unused]] std::vector<Part>& parts, [[maybe_unused]] void*& block) {
#if defined(LBDEM_HAVE_CUDA)
    std::size_t total = 0;
    for (const Part& p : parts) total += (p.bytes + 255) / 256 * 256;
    if (total == 0) return;
    LBDEM_CUDA_CHECK(cudaMallocHost(&block, total));
    std::size_t off = 0;
    for (Part& p : parts) {
      p.host = static_cast<std::byte*>(block) + off;
      off += (p.bytes + 255) / 256 * 256;
    }
#endif
  }
  void free_staging() {
#if defined(LBDEM_HAVE_CUDA)
    for (void** b : {&send_stage_, &recv_stage_})
      if (*b != nullptr) {
        (void)cudaFreeHost(*b);  // also runs from the destructor: no throw
        *b = nullptr;
      }
#endif
  }

  const Comm& comm_;
  Backend backend_;
  bool staged_;
  MPI_Comm mpi_ = MPI_COMM_NULL;
  std::vector<SelfCopy> self_;
  std::vector<Part> sends_, recvs_;
  std::vector<MPI_Request> requests_;
  void* send_stage_ = nullptr;
  void* recv_stage_ = nullptr;
  bool in_flight_ = false;
  TransportTimes times_;
};

}  // namespace
#endif

namespace {

// Without MPI there is one rank: the only messages are those a rank sends
// itself, copied locally.
class LocalTransport final : public Transport {
 public:
  LocalTransport(const Comm& comm, Backend backend, bool staged) : comm_(comm), backend_(backend), staged_(staged) {}
  void bind(std::vector<Message> messages) override {
    if (in_flight_) throw Error("halo transport: bind() between start() and finish()");
    validate_messages(messages, comm_, to_string(kind()));
    self_ = self_copies(messages, comm_);
  }
  void start(const Exec& ex) override {
    const auto t0 = Clock::now();
    if (ex.backend() != backend_) throw Error("halo transport: start() on another backend than it was made for");
    if (in_flight_) throw Error("halo transport: start() twice without finish()");
    run_self_copies(self_, ex);
    in_flight_ = true;
    times_.start = seconds_since(t0);
  }
  void finish(const Exec&) override {
    if (!in_flight_) throw Error("halo transport: finish() without start()");
    in_flight_ = false;
    times_.finish = 0;
  }
  TransportKind kind() const override {
    return backend_ == Backend::Cuda && !staged_ ? TransportKind::DeviceMpi : TransportKind::HostMpi;
  }
  const TransportTimes& times() const override { return times_; }

 private:
  const Comm& comm_;
  Backend backend_;
  bool staged_;
  std::vector<SelfCopy> self_;
  bool in_flight_ = false;
  TransportTimes times_;
};

}  // namespace

std::unique_ptr<Transport> make_mpi_transport(const Comm& comm, Backend backend, bool staged) {
#if defined(LBDEM_HAVE_MPI)
  if (comm.native() != nullptr) return std::make_unique<MpiTransport>(comm, backend, staged);
#endif
  return std::make_unique<LocalTransport>(comm, backend, staged);
}

}  // namespace lbdem::halo::detail
