#pragma once
// Private to halo/src: call checks for MPI and NCCL, the MPI handles behind
// Comm, and the parts every transport shares (message checks, the local copy
// of messages a rank sends to itself, the timing).
#include <chrono>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "halo/transport.hpp"

#if defined(LBDEM_HAVE_MPI)
#include <mpi.h>
#endif

namespace lbdem::halo::detail {

#if defined(LBDEM_HAVE_MPI)
// Throws lbdem::Error naming the call and MPI's error string. The
// communicators Comm creates return errors (MPI_ERRORS_RETURN) instead of
// aborting, so these checks see them.
[[noreturn]] void throw_mpi_error(int code, const char* call);
inline void check_mpi(int code, const char* call) {
  if (code != MPI_SUCCESS) throw_mpi_error(code, call);
}
#define LBDEM_MPI_CHECK(call) ::lbdem::halo::detail::check_mpi((call), #call)

inline MPI_Comm mpi_comm(const Comm& c) { return *static_cast<MPI_Comm*>(c.native()); }
#endif

// Largest message MPI takes in one call (int count of bytes).
inline constexpr std::size_t kMaxMpiMessageBytes = 1u << 30;
// Tags of halo messages (transport.hpp: 0..63).
inline constexpr int kMaxTransportTag = 63;

// Checks a message list (peers in range, tags in range, (peer, tag) unique for
// sends and (peer, recv_tag) unique for receives, buffers present where sizes
// are not zero, sizes MPI can carry); throws Error naming the message.
void validate_messages(const std::vector<Message>& messages, const Comm& comm, const char* transport);

// Tells every peer the size of each message it will get and checks it against
// the size it expects (a mismatch is a bug in the caller's message lists; it
// is found here once instead of as a truncated receive later). Collective
// among the peers of the list.
void check_sizes_with_peers(const std::vector<Message>& messages, const Comm& comm, const char* transport);

// For each message a rank sends to itself: the index of the message whose
// receive it fills ((self, tag) == (self, recv_tag)).
struct SelfCopy {
  const void* src = nullptr;
  void* dst = nullptr;
  std::size_t bytes = 0;
};
std::vector<SelfCopy> self_copies(const std::vector<Message>& messages, const Comm& comm);

// Copies on `backend` queued on ex (the host copies at once).
void run_self_copies(const std::vector<SelfCopy>& copies, const Exec& ex);

// Bytes and messages that leave this rank per step.
TransportTimes traffic(const std::vector<Message>& messages, const Comm& comm);

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The transports (transport_mpi.cpp, transport_nccl.cpp).
std::unique_ptr<Transport> make_mpi_transport(const Comm& comm, Backend backend, bool staged);
#if defined(LBDEM_HAVE_NCCL)
std::unique_ptr<Transport> make_nccl_transport(const Comm& comm);
#endif

}  // namespace lbdem::halo::detail
