#pragma once
// Moving packed halo buffers between neighbour ranks, behind one interface.
//
// A physics module (lbm/ populations, imb/ forces) packs what a neighbour
// needs into one buffer per neighbour with a kernel, hands the list of
// messages to a Transport once (bind), and then every step calls
//   pack kernels -> start(ex) -> other work -> finish(ex) -> unpack kernels
// on the same Exec (stream). Buffers live where the backend computes (device
// memory on the CUDA backend); the transport stages them through pinned host
// memory where the library needs it. No allocation after bind().
//
// Message matching: a message is identified by (peer, tag). Two messages to
// the same peer must carry different tags (two faces of a periodic axis cut
// in two are two messages to one rank). NCCL has no tags: the transports
// order sends and receives by (peer, tag), so both sides agree. A message to
// this rank itself is a local copy (on ex's stream on the CUDA backend).
//
// Collective calls: make_transport() on all ranks of the Comm, in the same
// order (each MPI transport gets its own communicator, so two transports in
// flight at once never confuse their tags; NCCL's communicator is made once);
// bind() among the peers of its message list (it checks once that each
// message's size is the size its peer expects, and throws Error otherwise).
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "core/exec.hpp"
#include "halo/comm.hpp"

namespace lbdem::halo {

enum class TransportKind {
  Auto,       // NCCL on GPUs when available, else device MPI when CUDA-aware, else host-staged MPI
  HostMpi,    // MPI on pinned host buffers (any MPI); on the host backend, MPI on the buffers themselves
  DeviceMpi,  // MPI on device buffers (needs a CUDA-aware MPI: MPIX_Query_cuda_support)
  Nccl,       // NCCL send/recv on the stream, bootstrapped through MPI
};

struct Message {
  int peer = -1;           // rank
  int tag = 0;             // 0..63, unique per (peer, direction)
  void* send = nullptr;    // backend memory
  std::size_t send_bytes = 0;
  int recv_tag = 0;        // tag of the message expected from `peer` into `recv`
  void* recv = nullptr;
  std::size_t recv_bytes = 0;
};

// Seconds spent in the last start() and finish() (host wall time from a
// steady clock, including the waits for staging copies and for the network;
// NCCL queues its work on the stream, so its times are only the queueing).
struct TransportTimes {
  double start = 0, finish = 0;
  std::size_t bytes_sent = 0;  // per step, to other ranks (local copies not counted)
  int messages = 0;            // per step, non-empty messages to other ranks
};

class Transport {
 public:
  virtual ~Transport() = default;
  // Fixes the message list (buffers, sizes, peers); allocates staging memory.
  // Checks the list (peers are ranks, tags 0..63, unique (peer, tag) and
  // (peer, recv_tag), sizes agreed with the peers) and throws Error if not.
  // May be called again (not while an exchange is in flight) to rebind.
  virtual void bind(std::vector<Message> messages) = 0;
  // Sends every bound buffer (after the packing work queued on ex) and posts
  // the receives. Returns without waiting for delivery.
  virtual void start(const Exec& ex) = 0;
  // After it returns, work queued on ex sees every received buffer.
  virtual void finish(const Exec& ex) = 0;
  virtual TransportKind kind() const = 0;
  virtual const TransportTimes& times() const = 0;
};

const char* to_string(TransportKind k);
// "auto", "host_mpi" (alias "mpi"), "device_mpi" (alias "cuda_aware_mpi"), "nccl";
// throws ConfigError naming `key`, the value and the valid names.
TransportKind parse_transport(const std::string& name, const std::string& key = "parallel.transport");
// True when the MPI library reports CUDA-aware support at run time.
bool mpi_cuda_aware();
bool nccl_compiled();

// True when every rank of `comm` computes on a GPU of its own (no two ranks
// of one host on the same device, compared by PCI bus id). Collective. On
// false, `clash` (when given) says which ranks share which device.
bool every_rank_has_own_gpu(const Comm& comm, std::string* clash = nullptr);

// The kind Auto picks for `backend` (collective): on the host backend, or on
// one rank (nothing to send), HostMpi; on the CUDA backend NCCL when built in
// and every rank has its own GPU, else DeviceMpi when the MPI is CUDA-aware,
// else HostMpi. Other kinds are returned as they are.
TransportKind resolve_transport(TransportKind kind, const Comm& comm, Backend backend);

// The transport of `kind` (Auto resolved as above) for buffers on `backend`.
// Collective over `comm`. Throws ResourceError naming `key` with the reason
// when that kind cannot run here (a device transport on the host backend,
// NCCL not built in, and with more than one rank: device MPI without a
// CUDA-aware MPI, NCCL with two ranks on one GPU).
std::unique_ptr<Transport> make_transport(TransportKind kind, const Comm& comm, Backend backend,
                                          const std::string& key = "parallel.transport");

}  // namespace lbdem::halo
