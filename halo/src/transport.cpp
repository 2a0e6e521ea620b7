// The transport interface's shared parts: names, message checks, local
// copies, which kind Auto picks and the checks that refuse a kind that cannot
// run here. The transports themselves: transport_mpi.cpp, transport_nccl.cpp.
#include "halo/transport.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <set>
#include <utility>

#include "transport_internal.hpp"

#if defined(LBDEM_HAVE_MPI)
#if __has_include(<mpi-ext.h>)
#include <mpi-ext.h>
#endif
#endif

namespace lbdem::halo {

const char* to_string(TransportKind k) {
  switch (k) {
    case TransportKind::Auto: return "auto";
    case TransportKind::HostMpi: return "host_mpi";
    case TransportKind::DeviceMpi: return "device_mpi";
    case TransportKind::Nccl: return "nccl";
  }
  return "?";
}

TransportKind parse_transport(const std::string& name, const std::string& key) {
  if (name == "auto") return TransportKind::Auto;
  if (name == "host_mpi" || name == "mpi") return TransportKind::HostMpi;
  if (name == "device_mpi" || name == "cuda_aware_mpi") return TransportKind::DeviceMpi;
  if (name == "nccl") return TransportKind::Nccl;
  throw ConfigError(key + ": '" + name +
                    "' is not a transport; valid: auto, host_mpi (alias mpi), device_mpi (alias cuda_aware_mpi), nccl");
}

bool mpi_cuda_aware() {
#if defined(LBDEM_HAVE_MPI) && defined(MPIX_CUDA_AWARE_SUPPORT)
#if MPIX_CUDA_AWARE_SUPPORT
  // The library was built with CUDA support; whether it is on is a run-time
  // question, and only an initialised MPI can answer it.
  int initialised = 0;
  LBDEM_MPI_CHECK(MPI_Initialized(&initialised));
  return initialised && MPIX_Query_cuda_support() == 1;
#else
  return false;
#endif
#else
  return false;
#endif
}

bool nccl_compiled() {
#if defined(LBDEM_HAVE_NCCL)
  return true;
#else
  return false;
#endif
}

namespace detail {

void validate_messages(const std::vector<Message>& messages, const Comm& comm, const char* transport) {
  std::set<std::pair<int, int>> sends, recvs;
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const Message& m = messages[i];
    const std::string what = std::string("halo transport ") + transport + ": message " + std::to_string(i) +
                             " (peer " + std::to_string(m.peer) + ", tag " + std::to_string(m.tag) +
                             ", recv_tag " + std::to_string(m.recv_tag) + ")";
    if (m.peer < 0 || m.peer >= comm.size())
      throw Error(what + ": peer is not a rank (0.." + std::to_string(comm.size() - 1) + ")");
    if (m.tag < 0 || m.tag > kMaxTransportTag || m.recv_tag < 0 || m.recv_tag > kMaxTransportTag)
      throw Error(what + ": tags must be 0.." + std::to_string(kMaxTransportTag));
    if ((m.send_bytes > 0 && m.send == nullptr) || (m.recv_bytes > 0 && m.recv == nullptr))
      throw Error(what + ": a buffer with a size but no memory");
    if (m.send_bytes > kMaxMpiMessageBytes || m.recv_bytes > kMaxMpiMessageBytes)
      throw Error(what + ": " + std::to_string(std::max(m.send_bytes, m.recv_bytes)) + " bytes; at most " +
                  std::to_string(kMaxMpiMessageBytes) + " per message");
    if (!sends.insert({m.peer, m.tag}).second)
      throw Error(what + ": a second message to the same peer with the same tag");
    if (!recvs.insert({m.peer, m.recv_tag}).second)
      throw Error(what + ": a second message from the same peer with the same recv_tag");
  }
}

void check_sizes_with_peers(const std::vector<Message>& messages, const Comm& comm, const char* transport) {
  std::vector<int> peers, tags, recv_tags;
  std::vector<std::vector<std::byte>> sizes;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const Message& m = messages[i];
    if (m.peer == comm.rank()) continue;  // checked by self_copies()
    std::vector<std::byte> b(sizeof(std::uint64_t));
    const std::uint64_t n = m.send_bytes;
    std::memcpy(b.data(), &n, sizeof n);
    peers.push_back(m.peer);
    tags.push_back(m.tag);
    recv_tags.push_back(m.recv_tag);
    sizes.push_back(std::move(b));
    index.push_back(i);
  }
  const auto got = comm.exchange(peers, tags, sizes, recv_tags);
  for (std::size_t k = 0; k < got.size(); ++k) {
    const Message& m = messages[index[k]];
    std::uint64_t n = 0;
    if (got[k].size() == sizeof n) std::memcpy(&n, got[k].data(), sizeof n);
    if (got[k].size() != sizeof n || n != m.recv_bytes)
      throw Error(std::string("halo transport ") + transport + ": rank " + std::to_string(m.peer) + " sends " +
                  std::to_string(n) + " bytes with tag " + std::to_string(m.recv_tag) + " to rank " +
                  std::to_string(comm.rank()) + ", which expects " + std::to_string(m.recv_bytes) +
                  " (the two ranks' message lists disagree)");
  }
}

std::vector<SelfCopy> self_copies(const std::vector<Message>& messages, const Comm& comm) {
  // Each entry to itself is one send and one receive, with unique tags and
  // unique recv_tags (validate_messages): matching every receive to a send
  // therefore uses every send once.
  std::vector<SelfCopy> out;
  for (const Message& r : messages) {
    if (r.peer != comm.rank()) continue;
    auto s = std::find_if(messages.begin(), messages.end(),
                          [&](const Message& m) { return m.peer == comm.rank() && m.tag == r.recv_tag; });
    if (s == messages.end() || s->send_bytes != r.recv_bytes)
      throw Error("halo transport: rank " + std::to_string(comm.rank()) + " expects " +
                  std::to_string(r.recv_bytes) + " bytes from itself with tag " + std::to_string(r.recv_tag) +
                  " but " +
                  (s == messages.end() ? std::string("sends itself no such message")
                                       : "sends " + std::to_string(s->send_bytes)));
    if (r.recv_bytes > 0) out.push_back({s->send, r.recv, r.recv_bytes});
  }
  return out;
}

void run_self_copies(const std::vector<SelfCopy>& copies, const Exec& ex) {
  for (const SelfCopy& c : copies) {
    if (ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
      LBDEM_CUDA_CHECK(cudaMemcpyAsync(c.dst, c.src, c.bytes, cudaMemcpyDefault, ex.stream()));
#else
      throw_not_compiled_for_cuda("halo transport (local copy)");
#endif
    } else {
      std::memcpy(c.dst, c.src, c.bytes);
    }
  }
}

TransportTimes traffic(const std::vector<Message>& messages, const Comm& comm) {
  TransportTimes t;
  for (const Message& m : messages)
    if (m.peer != comm.rank() && m.send_bytes > 0) {
      t.bytes_sent += m.send_bytes;
      ++t.messages;
    }
  return t;
}

}  // namespace detail

namespace {

// "node\nhost name\nPCI bus id" of this rank's current device (an empty bus
// id without a usable device).
std::string node_and_device(const Comm& comm) {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  std::string bus;
#if defined(LBDEM_HAVE_CUDA)
  int dev = -1;
  if (cudaGetDevice(&dev) == cudaSuccess) {
    char id[64] = {};
    if (cudaDeviceGetPCIBusId(id, sizeof id, dev) == cudaSuccess) bus = id;
  }
  (void)cudaGetLastError();  // no device: reported as an empty bus id
#endif
  return std::to_string(comm.node()) + "\n" + host + "\n" + bus;
}

}  // namespace

bool every_rank_has_own_gpu(const Comm& comm, std::string* clash) {
  const std::string mine = node_and_device(comm);
  const auto* p = reinterpret_cast<const std::byte*>(mine.data());
  const auto all = comm.allgather(std::span<const std::byte>(p, mine.size()));
  struct Where {
    std::string node, host, bus;
  };
  std::vector<Where> w;
  for (const auto& b : all) {
    const std::string s(reinterpret_cast<const char*>(b.data()), b.size());
    const auto a = s.find('\n'), z = s.rfind('\n');
    w.push_back({s.substr(0, a), s.substr(a + 1, z - a - 1), s.substr(z + 1)});
  }
  // Every rank sees the same list, so every rank gives the same answer.
  for (std::size_t a = 0; a < w.size(); ++a) {
    if (w[a].bus.empty()) {
      if (clash) *clash = "rank " + std::to_string(a) + " on host " + w[a].host + " has no usable GPU";
      return false;
    }
    for (std::size_t b = a + 1; b < w.size(); ++b)
      if (w[a].node == w[b].node && w[a].bus == w[b].bus) {
        if (clash)
          *clash = "ranks " + std::to_string(a) + " and " + std::to_string(b) + " on host " + w[a].host +
                   " share the GPU at PCI bus id " + w[a].bus;
        return false;
      }
  }
  return true;
}

TransportKind resolve_transport(TransportKind kind, const Comm& comm, Backend backend) {
  if (kind != TransportKind::Auto) return kind;
  if (backend == Backend::Host || !comm.distributed()) return TransportKind::HostMpi;
  if (nccl_compiled() && every_rank_has_own_gpu(comm)) return TransportKind::Nccl;
  // All ranks run one MPI library, but each asks it: agree on the answer.
  if (comm.all(mpi_cuda_aware())) return TransportKind::DeviceMpi;
  return TransportKind::HostMpi;
}

std::unique_ptr<Transport> make_transport(TransportKind requested, const Comm& comm, Backend backend,
                                          const std::string& key) {
  const TransportKind kind = resolve_transport(requested, comm, backend);
  const std::string named = key + ": '" + to_string(kind) + "'";
  if (backend == Backend::Host) {
    if (kind != TransportKind::HostMpi)
      throw ResourceError(named + " moves device buffers, but this run computes on the CPU; use host_mpi or auto");
    return detail::make_mpi_transport(comm, backend, false);
  }
  if (!cuda_compiled())
    throw ResourceError(named + ": this binary was built without the CUDA backend");
  switch (kind) {
    case TransportKind::HostMpi:
      return detail::make_mpi_transport(comm, backend, true);
    case TransportKind::DeviceMpi:
      if (comm.distributed() && !comm.all(mpi_cuda_aware()))
        throw ResourceError(named + ": the MPI library is not CUDA-aware (MPIX_Query_cuda_support() does not "
                                    "report it on every rank); use host_mpi (pinned host buffers) or auto");
      return detail::make_mpi_transport(comm, backend, false);
    case TransportKind::Nccl: {
#if defined(LBDEM_HAVE_NCCL)
      std::string clash;
      if (comm.distributed() && !every_rank_has_own_gpu(comm, &clash))
        throw ResourceError(named + " needs one GPU per rank, but " + clash +
                            "; run at most as many ranks per node as GPUs, or use host_mpi");
      return detail::make_nccl_transport(comm);
#else
      throw ResourceError(named + ": NCCL was not found when lbdem was built (nccl.h and libnccl); use host_mpi, "
                                  "device_mpi or auto");
#endif
    }
    case TransportKind::Auto: break;
  }
  throw Error(named + ": unresolved transport kind");
}

}  // namespace lbdem::halo
