// The halo transports on 1..4 ranks. Each rank sends one face message to
// the rank on its left (tag 0) and one to the rank on its right (tag 1), of
// different sizes, and receives the matching faces of its neighbours:
//  - on a periodic ring (left = previous rank, right = next rank; on one rank
//    both are the rank itself, on two they are one peer);
//  - in periodic pairs (ranks 0-1, 2-3, ...: both faces go to one peer, and
//    only the tags keep them apart; an odd last rank is its own pair).
// Repeated 100 times with new data each time, with no heap allocation in
// start()/finish(). Host-backend cases run everywhere; the CUDA cases (each
// kind) run where a GPU is usable and skip otherwise, or where the kind
// cannot run here (not CUDA-aware, two ranks on one GPU), saying why.
#include <gtest/gtest.h>

#include <cstring>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include "alloc_count.hpp"
#include "core/buffer.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "halo/comm.hpp"
#include "halo/device.hpp"
#include "halo/transport.hpp"

namespace lbdem::halo {
namespace {

const Comm& comm() { return Comm::world(); }

bool gpu_usable() { return cuda_unavailable_reason().empty(); }

// Doubles per face message: the left face carries more than the right, so a
// swap of the two messages to one peer is caught by size and by content.
constexpr Index kLeftCount = 5 * 24;
constexpr Index kRightCount = 3 * 24;

// Rank `sender`'s face `face` (0 left, 1 right) at iteration `it`, entry i.
double face_value(int sender, int face, int it, Index i) {
  return 1000.0 * sender + 100.0 * face + it + 1e-3 * static_cast<double>(i);
}

struct Neighbours {
  int left, right;
};
Neighbours ring() {
  const int n = comm().size(), r = comm().rank();
  return {(r + n - 1) % n, (r + 1) % n};
}
Neighbours pair() {
  const int partner = comm().rank() ^ 1;
  const int p = partner < comm().size() ? partner : comm().rank();
  return {p, p};
}

// One rank's buffers for the two faces, on `backend`.
struct Faces {
  Buffer<double> send_left, send_right, recv_left, recv_right;
  explicit Faces(Backend b)
      : send_left(b, kLeftCount), send_right(b, kRightCount), recv_left(b, kRightCount), recv_right(b, kLeftCount) {}
  std::vector<Message> messages(Neighbours nb) {
    constexpr std::size_t d = sizeof(double);
    // To the left with tag 0; from the left its right face (tag 1).
    Message left{nb.left, 0, send_left.data(), kLeftCount * d, 1, recv_left.data(), kRightCount * d};
    Message right{nb.right, 1, send_right.data(), kRightCount * d, 0, recv_right.data(), kLeftCount * d};
    return {left, right};
  }
};

struct Scratch {
  std::vector<double> left = std::vector<double>(kLeftCount), right = std::vector<double>(kRightCount);
  std::vector<double> got_left = std::vector<double>(kRightCount), got_right = std::vector<double>(kLeftCount);
};

void pack(Faces& f, Scratch& s, int it) {
  for (Index i = 0; i < kLeftCount; ++i) s.left[static_cast<std::size_t>(i)] = face_value(comm().rank(), 0, it, i);
  for (Index i = 0; i < kRightCount; ++i) s.right[static_cast<std::size_t>(i)] = face_value(comm().rank(), 1, it, i);
  f.send_left.copy_from_host(s.left);
  f.send_right.copy_from_host(s.right);
}

// Number of wrong entries after iteration `it` (the first one described in `first`).
long check(Faces& f, Scratch& s, Neighbours nb, int it, std::string& first) {
  f.recv_left.copy_to_host(s.got_left.data(), kRightCount);
  f.recv_right.copy_to_host(s.got_right.data(), kLeftCount);
  long bad = 0;
  for (Index i = 0; i < kRightCount; ++i)
    if (s.got_left[static_cast<std::size_t>(i)] != face_value(nb.left, 1, it, i) && bad++ == 0)
      first = "left ghost entry " + std::to_string(i) + " = " + std::to_string(s.got_left[static_cast<std::size_t>(i)]);
  for (Index i = 0; i < kLeftCount; ++i)
    if (s.got_right[static_cast<std::size_t>(i)] != face_value(nb.right, 0, it, i) && bad++ == 0)
      first =
          "right ghost entry " + std::to_string(i) + " = " + std::to_string(s.got_right[static_cast<std::size_t>(i)]);
  return bad;
}

struct Case {
  Backend backend;
  TransportKind kind;
};
void PrintTo(const Case& c, std::ostream* os) { *os << to_string(c.backend) << " " << to_string(c.kind); }
std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  return std::string(to_string(info.param.backend)) + "_" + to_string(info.param.kind);
}

class TransportExchange : public ::testing::TestWithParam<Case> {
 protected:
  // The transport of this case, or nullptr after GTEST_SKIP (the reason is
  // the same on every rank: the checks behind it are collective).
  std::unique_ptr<Transport> make() {
    const Case c = GetParam();
    if (c.backend == Backend::Cuda) {
      if (!gpu_usable()) return nullptr;
      select_device(comm());
    }
    try {
      return make_transport(c.kind, comm(), c.backend);
    } catch (const ResourceError& e) {
      if (c.backend == Backend::Cuda && c.kind != TransportKind::HostMpi) {
        skip_reason_ = e.what();
        return nullptr;
      }
      throw;
    }
  }
  void SetUp() override {
    if (GetParam().backend == Backend::Cuda && !gpu_usable()) GTEST_SKIP() << cuda_unavailable_reason();
  }

  void run(Neighbours nb, int iterations) {
    auto t = make();
    if (!t) GTEST_SKIP() << skip_reason_;
    const Backend b = GetParam().backend;
    if (GetParam().kind != TransportKind::Auto) {
      EXPECT_EQ(t->kind(), GetParam().kind);
    }
    Exec ex(b);
    Faces f(b);
    Scratch s;
    t->bind(f.messages(nb));
    const int remote = (nb.left != comm().rank()) + (nb.right != comm().rank());
    EXPECT_EQ(t->times().messages, remote);
    const std::size_t bytes = (nb.left != comm().rank() ? kLeftCount : 0) + (nb.right != comm().rank() ? kRightCount : 0);
    EXPECT_EQ(t->times().bytes_sent, bytes * sizeof(double));

    long allocations = 0, wrong = 0;
    std::string first;
    for (int it = 0; it < iterations; ++it) {
      pack(f, s, it);
      const long a0 = test::heap_allocations();
      t->start(ex);
      t->finish(ex);
      allocations += test::heap_allocations() - a0;
      ex.synchronize();
      const long w = check(f, s, nb, it, first);
      if (w > 0 && wrong == 0) first = "iteration " + std::to_string(it) + ": " + first;
      wrong += w;
    }
    EXPECT_EQ(wrong, 0) << first;
    // NCCL's own C++ internals may allocate inside ncclGroupEnd; the MPI
    // transports' start()/finish() (and the C MPI library) must not.
    if (t->kind() != TransportKind::Nccl) {
      EXPECT_EQ(allocations, 0) << "start()/finish() allocated";
    }
    EXPECT_GE(t->times().start, 0.0);
    EXPECT_GE(t->times().finish, 0.0);
  }

  std::string skip_reason_;
};

TEST_P(TransportExchange, PeriodicRing100Times) { run(ring(), 100); }

TEST_P(TransportExchange, PeriodicPairBothFacesToOnePeer100Times) { run(pair(), 100); }

// Two transports in flight at once with the same tags and peers (as the
// populations and the forces of one step may be): each delivers its own.
TEST_P(TransportExchange, TwoTransportsInFlightKeepApart) {
  auto a = make();
  if (!a) GTEST_SKIP() << skip_reason_;
  auto b = make();
  const Backend be = GetParam().backend;
  Exec ex(be);
  Faces fa(be), fb(be);
  Scratch sa, sb;
  const Neighbours nb = ring();
  a->bind(fa.messages(nb));
  b->bind(fb.messages(nb));
  for (int it = 0; it < 3; ++it) {
    pack(fa, sa, it);
    pack(fb, sb, it + 50);
    a->start(ex);
    b->start(ex);
    b->finish(ex);
    a->finish(ex);
    ex.synchronize();
    std::string first;
    EXPECT_EQ(check(fa, sa, nb, it, first), 0) << "first transport, iteration " << it << ": " << first;
    EXPECT_EQ(check(fb, sb, nb, it + 50, first), 0) << "second transport, iteration " << it << ": " << first;
  }
}

// Message lists that disagree between two ranks (here every rank expects one
// double too many from its left) are refused by bind() on the receiving side.
TEST_P(TransportExchange, SizeMismatchWithPeerIsRefused) {
  auto t = make();
  if (!t) GTEST_SKIP() << skip_reason_;
  Faces f(GetParam().backend);
  auto m = f.messages(ring());
  m[0].recv_bytes -= sizeof(double);
  EXPECT_THROW(t->bind(m), Error);
}

std::vector<Case> cases() {
  return {{Backend::Host, TransportKind::HostMpi}, {Backend::Host, TransportKind::Auto},
          {Backend::Cuda, TransportKind::HostMpi}, {Backend::Cuda, TransportKind::DeviceMpi},
          {Backend::Cuda, TransportKind::Nccl},    {Backend::Cuda, TransportKind::Auto}};
}
INSTANTIATE_TEST_SUITE_P(Kinds, TransportExchange, ::testing::ValuesIn(cases()), case_name);

TEST(Transport, BadMessageListsAreRefusedBeforeAnyMessage) {
  auto t = make_transport(TransportKind::HostMpi, comm(), Backend::Host);
  std::vector<double> a(4), b(4);
  const std::size_t n = sizeof(double) * 4;
  const int me = comm().rank();
  const auto one = [&](Message m) { return std::vector<Message>{m}; };
  EXPECT_THROW(t->bind(one({comm().size(), 0, a.data(), n, 0, b.data(), n})), Error);  // not a rank
  EXPECT_THROW(t->bind(one({-1, 0, a.data(), n, 0, b.data(), n})), Error);
  EXPECT_THROW(t->bind(one({me, 64, a.data(), n, 64, b.data(), n})), Error);           // tag out of range
  EXPECT_THROW(t->bind(one({me, 0, nullptr, n, 0, b.data(), n})), Error);              // size without memory
  EXPECT_THROW(t->bind({{me, 2, a.data(), n, 2, b.data(), n}, {me, 2, a.data(), n, 3, b.data(), n}}), Error);
  EXPECT_THROW(t->bind(one({me, 1, a.data(), n, 2, b.data(), n})), Error);  // a receive from itself never sent
  // A valid message to itself is a copy.
  a = {1, 2, 3, 4};
  t->bind(one({me, 7, a.data(), n, 7, b.data(), n}));
  Exec ex(Backend::Host);
  t->start(ex);
  t->finish(ex);
  EXPECT_EQ(b, a);
  EXPECT_EQ(t->times().messages, 0);
  EXPECT_THROW(t->finish(ex), Error);  // finish() without start()
}

TEST(Transport, DeviceKindsAreRefusedOnTheHostBackend) {
  EXPECT_EQ(make_transport(TransportKind::Auto, comm(), Backend::Host)->kind(), TransportKind::HostMpi);
  EXPECT_EQ(resolve_transport(TransportKind::Auto, comm(), Backend::Host), TransportKind::HostMpi);
  for (TransportKind k : {TransportKind::DeviceMpi, TransportKind::Nccl}) {
    try {
      make_transport(k, comm(), Backend::Host, "parallel.transport");
      ADD_FAILURE() << to_string(k) << " accepted on the host backend";
    } catch (const ResourceError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("parallel.transport"), std::string::npos) << msg;
      EXPECT_NE(msg.find(to_string(k)), std::string::npos) << msg;
    }
  }
  if (!nccl_compiled() && cuda_compiled()) {
    EXPECT_THROW(make_transport(TransportKind::Nccl, comm(), Backend::Cuda), ResourceError);
  }
}

TEST(Transport, NamesParseAndBadNamesSayWhatIsValid) {
  EXPECT_EQ(parse_transport("auto"), TransportKind::Auto);
  EXPECT_EQ(parse_transport("host_mpi"), TransportKind::HostMpi);
  EXPECT_EQ(parse_transport("mpi"), TransportKind::HostMpi);
  EXPECT_EQ(parse_transport("device_mpi"), TransportKind::DeviceMpi);
  EXPECT_EQ(parse_transport("cuda_aware_mpi"), TransportKind::DeviceMpi);
  EXPECT_EQ(parse_transport("nccl"), TransportKind::Nccl);
  for (TransportKind k : {TransportKind::Auto, TransportKind::HostMpi, TransportKind::DeviceMpi, TransportKind::Nccl})
    EXPECT_EQ(parse_transport(to_string(k)), k);
  try {
    parse_transport("infiniband", "run.transport");
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    for (const char* s : {"run.transport", "infiniband", "host_mpi", "device_mpi", "nccl", "auto"})
      EXPECT_NE(msg.find(s), std::string::npos) << msg;
  }
}

TEST(Transport, SelectDeviceFollowsTheLocalRank) {
  const int d = select_device(comm());
  std::string clash;
  const bool own = every_rank_has_own_gpu(comm(), &clash);
  if (!gpu_usable()) {
    EXPECT_EQ(d, -1);
    EXPECT_FALSE(own);
    EXPECT_NE(clash.find("no usable GPU"), std::string::npos) << clash;
    EXPECT_NE(resolve_transport(TransportKind::Auto, comm(), Backend::Cuda), TransportKind::Nccl);
    return;
  }
#if defined(LBDEM_HAVE_CUDA)
  int n = 0;
  ASSERT_EQ(cudaGetDeviceCount(&n), cudaSuccess);
  EXPECT_EQ(d, comm().local_rank() % n);
  int current = -1;
  ASSERT_EQ(cudaGetDevice(&current), cudaSuccess);
  EXPECT_EQ(current, d);
  // Whether two ranks share a GPU follows from the GPUs they hold, not from
  // the count each one sees: under CTest's resource groups every rank sees
  // only its own GPU (CUDA_VISIBLE_DEVICES), one of n = 1, yet no two share.
  char bus[64] = {};
  ASSERT_EQ(cudaDeviceGetPCIBusId(bus, sizeof bus, d), cudaSuccess);
  const std::string mine(bus);
  const auto all = comm().allgather(std::as_bytes(std::span<const char>(mine.data(), mine.size())));
  bool shared = false;
  for (std::size_t a = 0; a < all.size(); ++a)
    for (std::size_t b = a + 1; b < all.size(); ++b) shared = shared || all[a] == all[b];
  if (shared) {
    EXPECT_THROW(select_device(comm(), TransportKind::Nccl), ResourceError);
    EXPECT_FALSE(own);
    EXPECT_NE(clash.find("share the GPU"), std::string::npos) << clash;
  } else {
    EXPECT_TRUE(own) << clash;
  }
#endif
}

}  // namespace
}  // namespace lbdem::halo
