#include "halo/comm.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "core/error.hpp"
#include "transport_internal.hpp"

namespace lbdem::halo {

bool mpi_compiled() {
#if defined(LBDEM_HAVE_MPI)
  return true;
#else
  return false;
#endif
}

namespace {

using detail::kMaxMpiMessageBytes;

// Variables the common launchers set in each process they start: Open MPI's
// mpirun, PMI-1/2 (MPICH's Hydra, Intel MPI, srun --mpi=pmi2), PMIx (Open MPI
// 5, srun --mpi=pmix) and MVAPICH's.
constexpr const char* kLauncherVariables[] = {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE",  "PMI_RANK",
                                              "PMIX_RANK",            "MV2_COMM_WORLD_SIZE"};

// Whether to start MPI: LBDEM_MPI=1/0 decides; otherwise a launcher's trace.
[[maybe_unused]] bool launched_by_mpi() {
  if (const char* force = std::getenv("LBDEM_MPI")) {
    const std::string f(force);
    if (f == "1") return true;
    if (f == "0") return false;
    throw ConfigError("environment variable LBDEM_MPI: '" + f +
                      "' is not valid; use 1 (start MPI) or 0 (one rank without MPI), or leave it unset");
  }
  for (const char* v : kLauncherVariables)
    if (std::getenv(v) != nullptr) return true;
  return false;
}

// Largest tag of exchange() (its messages use MPI tags 2 tag and 2 tag + 1,
// and MPI guarantees tags up to 32767).
constexpr int kMaxExchangeTag = 16000;

#if defined(LBDEM_HAVE_MPI)
// Tags of the messages behind the collectives on the private communicator.
// exchange() uses 2 * tag (sizes) and 2 * tag + 1 (bytes) below this.
constexpr int kGatherTag = 32766;

MPI_Comm own_comm(void* own) { return *static_cast<MPI_Comm*>(own); }

int as_count(std::size_t n) { return static_cast<int>(n); }

// Sends/receives `bytes` in pieces MPI counts can hold, all with one tag
// (messages between two ranks with one tag arrive in the order sent).
void send_all(const std::byte* p, std::size_t n, int peer, int tag, MPI_Comm c) {
  for (std::size_t off = 0; off < n; off += kMaxMpiMessageBytes) {
    const std::size_t len = std::min(kMaxMpiMessageBytes, n - off);
    LBDEM_MPI_CHECK(MPI_Send(p + off, as_count(len), MPI_BYTE, peer, tag, c));
  }
}
void recv_all(std::byte* p, std::size_t n, int peer, int tag, MPI_Comm c) {
  for (std::size_t off = 0; off < n; off += kMaxMpiMessageBytes) {
    const std::size_t len = std::min(kMaxMpiMessageBytes, n - off);
    LBDEM_MPI_CHECK(MPI_Recv(p + off, as_count(len), MPI_BYTE, peer, tag, c, MPI_STATUS_IGNORE));
  }
}
void isend_all(const std::byte* p, std::size_t n, int peer, int tag, MPI_Comm c, std::vector<MPI_Request>& reqs) {
  for (std::size_t off = 0; off < n; off += kMaxMpiMessageBytes) {
    const std::size_t len = std::min(kMaxMpiMessageBytes, n - off);
    reqs.emplace_back();
    LBDEM_MPI_CHECK(MPI_Isend(p + off, as_count(len), MPI_BYTE, peer, tag, c, &reqs.back()));
  }
}
void irecv_all(std::byte* p, std::size_t n, int peer, int tag, MPI_Comm c, std::vector<MPI_Request>& reqs) {
  for (std::size_t off = 0; off < n; off += kMaxMpiMessageBytes) {
    const std::size_t len = std::min(kMaxMpiMessageBytes, n - off);
    reqs.emplace_back();
    LBDEM_MPI_CHECK(MPI_Irecv(p + off, as_count(len), MPI_BYTE, peer, tag, c, &reqs.back()));
  }
}
void wait_all(std::vector<MPI_Request>& reqs) {
  if (reqs.empty()) return;
  LBDEM_MPI_CHECK(MPI_Waitall(as_count(reqs.size()), reqs.data(), MPI_STATUSES_IGNORE));
  reqs.clear();
}
#endif

void check_root(int root, int size, const char* what) {
  if (root < 0 || root >= size)
    throw Error(std::string("Comm::") + what + ": root " + std::to_string(root) + " is not a rank (0.." +
                std::to_string(size - 1) + ")");
}

}  // namespace

#if defined(LBDEM_HAVE_MPI)
namespace detail {
void throw_mpi_error(int code, const char* call) {
  char text[MPI_MAX_ERROR_STRING] = {};
  int len = 0;
  if (MPI_Error_string(code, text, &len) != MPI_SUCCESS) len = 0;
  throw Error(std::string("MPI call failed: ") + call + " -> " +
              (len > 0 ? std::string(text, static_cast<std::size_t>(len)) : "error " + std::to_string(code)));
}
}  // namespace detail
#endif

Comm& Comm::world() {
  static Comm w;
  return w;
}

Comm::Comm() {
#if defined(LBDEM_HAVE_MPI)
  if (!launched_by_mpi()) {
    why_single_ = "not started by an MPI launcher";
    return;
  }
  int initialised = 0;
  LBDEM_MPI_CHECK(MPI_Initialized(&initialised));
  if (!initialised) {
    // FUNNELED: OpenMP threads never call MPI; the thread that made Comm does.
    int provided = 0;
    LBDEM_MPI_CHECK(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided));
    owns_mpi_ = true;
  }
  auto* transports = new MPI_Comm(MPI_COMM_NULL);
  auto* own = new MPI_Comm(MPI_COMM_NULL);
  native_ = transports;
  own_ = own;
  LBDEM_MPI_CHECK(MPI_Comm_dup(MPI_COMM_WORLD, transports));
  LBDEM_MPI_CHECK(MPI_Comm_dup(MPI_COMM_WORLD, own));
  LBDEM_MPI_CHECK(MPI_Comm_set_errhandler(*transports, MPI_ERRORS_RETURN));
  LBDEM_MPI_CHECK(MPI_Comm_set_errhandler(*own, MPI_ERRORS_RETURN));
  LBDEM_MPI_CHECK(MPI_Comm_rank(*own, &rank_));
  LBDEM_MPI_CHECK(MPI_Comm_size(*own, &size_));
  // The ranks that share memory with this one are the ranks of its node.
  MPI_Comm node = MPI_COMM_NULL;
  LBDEM_MPI_CHECK(MPI_Comm_split_type(*own, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node));
  LBDEM_MPI_CHECK(MPI_Comm_rank(node, &local_rank_));
  LBDEM_MPI_CHECK(MPI_Comm_size(node, &local_size_));
  node_ = rank_;
  LBDEM_MPI_CHECK(MPI_Allreduce(MPI_IN_PLACE, &node_, 1, MPI_INT, MPI_MIN, node));
  LBDEM_MPI_CHECK(MPI_Comm_free(&node));
#else
  why_single_ = "built without MPI";
#endif
}

Comm::~Comm() {
#if defined(LBDEM_HAVE_MPI)
  // Runs at exit (Comm::world() is a function-local static). Objects made
  // after world() that still hold MPI or NCCL resources are destroyed first.
  int finalised = 1;
  MPI_Finalized(&finalised);
  if (!finalised) {
    for (void* h : {native_, own_})
      if (h != nullptr && *static_cast<MPI_Comm*>(h) != MPI_COMM_NULL) MPI_Comm_free(static_cast<MPI_Comm*>(h));
    if (owns_mpi_) MPI_Finalize();
  }
  delete static_cast<MPI_Comm*>(native_);
  delete static_cast<MPI_Comm*>(own_);
#endif
}

std::string Comm::describe() const {
  if (!why_single_.empty()) {
    std::string s = "single rank (";
    s.append(why_single_).append(")");
    return s;
  }
  std::string s = "mpi (" + std::to_string(size_) + (size_ == 1 ? " rank" : " ranks");
  if (size_ > 1) s += ", " + std::to_string(local_size_) + " on this node";
  return s + ")";
}

void Comm::barrier() const {
#if defined(LBDEM_HAVE_MPI)
  if (own_ != nullptr) LBDEM_MPI_CHECK(MPI_Barrier(own_comm(own_)));
#endif
}

double Comm::sum(double v) const {
  if (size_ == 1) return v;
  std::vector<double> all(static_cast<std::size_t>(size_));
#if defined(LBDEM_HAVE_MPI)
  LBDEM_MPI_CHECK(MPI_Allgather(&v, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, own_comm(own_)));
#endif
  // Rank order, whatever the MPI library's reduction tree: the same rank
  // count gives the same bits.
  double s = all[0];
  for (std::size_t r = 1; r < all.size(); ++r) s += all[r];
  return s;
}

void Comm::sum(std::span<double> v) const {
  if (size_ == 1 || v.empty()) return;
#if defined(LBDEM_HAVE_MPI)
  // In blocks, so the gathered copy stays small (32 MiB) whatever v's size.
  const std::size_t ranks = static_cast<std::size_t>(size_);
  const std::size_t block = std::max<std::size_t>(1, (std::size_t{1} << 22) / ranks);
  std::vector<double> all(std::min(block, v.size()) * ranks);
  for (std::size_t b0 = 0; b0 < v.size(); b0 += block) {
    const std::size_t n = std::min(block, v.size() - b0);
    LBDEM_MPI_CHECK(
        MPI_Allgather(v.data() + b0, as_count(n), MPI_DOUBLE, all.data(), as_count(n), MPI_DOUBLE, own_comm(own_)));
    for (std::size_t i = 0; i < n; ++i) {
      double s = all[i];
      for (std::size_t r = 1; r < ranks; ++r) s += all[r * n + i];
      v[b0 + i] = s;
    }
  }
#endif
}

// One value reduced over the ranks with `op` (in place; identity on one rank).
#if defined(LBDEM_HAVE_MPI)
#define LBDEM_COMM_REDUCE(v, type, op) \
  do {                                  \
    if (size_ > 1) LBDEM_MPI_CHECK(MPI_Allreduce(MPI_IN_PLACE, &(v), 1, type, op, own_comm(own_))); \
  } while (0)
#else
#define LBDEM_COMM_REDUCE(v, type, op) (void)0
#endif

long Comm::sum(long v) const {
  LBDEM_COMM_REDUCE(v, MPI_LONG, MPI_SUM);
  return v;
}
double Comm::max(double v) const {
  LBDEM_COMM_REDUCE(v, MPI_DOUBLE, MPI_MAX);
  return v;
}
double Comm::min(double v) const {
  LBDEM_COMM_REDUCE(v, MPI_DOUBLE, MPI_MIN);
  return v;
}
long Comm::max(long v) const {
  LBDEM_COMM_REDUCE(v, MPI_LONG, MPI_MAX);
  return v;
}
long Comm::min(long v) const {
  LBDEM_COMM_REDUCE(v, MPI_LONG, MPI_MIN);
  return v;
}

bool Comm::any(bool v) const {
  int x = v ? 1 : 0;
#if defined(LBDEM_HAVE_MPI)
  if (size_ > 1) LBDEM_MPI_CHECK(MPI_Allreduce(MPI_IN_PLACE, &x, 1, MPI_INT, MPI_LOR, own_comm(own_)));
#endif
  return x != 0;
}

std::pair<double, int> Comm::maxloc(double v) const {
  if (size_ == 1) return {v, 0};
  // Gathered and scanned here rather than MPI_MAXLOC, so the rule is ours:
  // the largest value, ties to the lowest rank.
  std::vector<double> all(static_cast<std::size_t>(size_));
#if defined(LBDEM_HAVE_MPI)
  LBDEM_MPI_CHECK(MPI_Allgather(&v, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, own_comm(own_)));
#endif
  int best = 0;
  for (int r = 1; r < size_; ++r)
    if (all[static_cast<std::size_t>(r)] > all[static_cast<std::size_t>(best)]) best = r;
  return {all[static_cast<std::size_t>(best)], best};
}

void Comm::broadcast([[maybe_unused]] std::vector<std::byte>& bytes, int root) const {
  check_root(root, size_, "broadcast");
  if (size_ == 1) return;
#if defined(LBDEM_HAVE_MPI)
  std::uint64_t n = bytes.size();
  LBDEM_MPI_CHECK(MPI_Bcast(&n, 1, MPI_UINT64_T, root, own_comm(own_)));
  if (rank_ != root) bytes.resize(static_cast<std::size_t>(n));
  for (std::size_t off = 0; off < n; off += kMaxMpiMessageBytes) {
    const std::size_t len = std::min<std::size_t>(kMaxMpiMessageBytes, n - off);
    LBDEM_MPI_CHECK(MPI_Bcast(bytes.data() + off, as_count(len), MPI_BYTE, root, own_comm(own_)));
  }
#endif
}

std::vector<std::vector<std::byte>> Comm::gather(std::span<const std::byte> mine, int root) const {
  check_root(root, size_, "gather");
  std::vector<std::vector<std::byte>> out;
  if (size_ == 1) {
    out.emplace_back(mine.begin(), mine.end());
    return out;
  }
#if defined(LBDEM_HAVE_MPI)
  const MPI_Comm c = own_comm(own_);
  std::uint64_t n = mine.size();
  std::vector<std::uint64_t> sizes(rank_ == root ? static_cast<std::size_t>(size_) : 0);
  LBDEM_MPI_CHECK(MPI_Gather(&n, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, root, c));
  if (rank_ != root) {
    send_all(mine.data(), mine.size(), root, kGatherTag, c);
    return out;
  }
  // Point to point in rank order: no int limit on the total, one rank's
  // bytes in flight at a time.
  out.resize(static_cast<std::size_t>(size_));
  for (int r = 0; r < size_; ++r) {
    auto& o = out[static_cast<std::size_t>(r)];
    if (r == root) {
      o.assign(mine.begin(), mine.end());
      continue;
    }
    o.resize(static_cast<std::size_t>(sizes[static_cast<std::size_t>(r)]));
    recv_all(o.data(), o.size(), r, kGatherTag, c);
  }
#endif
  return out;
}

std::vector<std::vector<std::byte>> Comm::allgather(std::span<const std::byte> mine) const {
  std::vector<std::vector<std::byte>> out;
  if (size_ == 1) {
    out.emplace_back(mine.begin(), mine.end());
    return out;
  }
#if defined(LBDEM_HAVE_MPI)
  const MPI_Comm c = own_comm(own_);
  const std::size_t ranks = static_cast<std::size_t>(size_);
  std::uint64_t n = mine.size();
  std::vector<std::uint64_t> sizes(ranks);
  LBDEM_MPI_CHECK(MPI_Allgather(&n, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, c));
  std::uint64_t total = 0;
  std::vector<int> counts(ranks), displs(ranks);
  for (std::size_t r = 0; r < ranks; ++r) {
    counts[r] = static_cast<int>(sizes[r]);
    displs[r] = static_cast<int>(total);
    total += sizes[r];
  }
  if (total > static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
    throw Error("Comm::allgather: " + std::to_string(total) +
                " bytes over all ranks; at most 2^31 - 1 (use gather() for large data)");
  std::vector<std::byte> all(static_cast<std::size_t>(total));
  LBDEM_MPI_CHECK(MPI_Allgatherv(mine.data(), as_count(mine.size()), MPI_BYTE, all.data(), counts.data(),
                                 displs.data(), MPI_BYTE, c));
  out.resize(ranks);
  for (std::size_t r = 0; r < ranks; ++r)
    out[r].assign(all.begin() + displs[r], all.begin() + displs[r] + counts[r]);
#endif
  return out;
}

std::vector<std::vector<std::byte>> Comm::exchange(std::span<const int> peers, std::span<const int> tags,
                                                   std::span<const std::vector<std::byte>> sends,
                                                   std::span<const int> recv_tags) const {
  if (tags.size() != peers.size() || sends.size() != peers.size() || recv_tags.size() != peers.size())
    throw Error("Comm::exchange: peers (" + std::to_string(peers.size()) + "), tags (" +
                std::to_string(tags.size()) + "), sends (" + std::to_string(sends.size()) + ") and recv_tags (" +
                std::to_string(recv_tags.size()) + ") must have one entry per peer");
  const std::size_t m = peers.size();
  for (std::size_t i = 0; i < m; ++i) {
    if (peers[i] < 0 || peers[i] >= size_)
      throw Error("Comm::exchange: peer " + std::to_string(peers[i]) + " is not a rank (0.." +
                  std::to_string(size_ - 1) + ")");
    for (int t : {tags[i], recv_tags[i]})
      if (t < 0 || t > kMaxExchangeTag)
        throw Error("Comm::exchange: tag " + std::to_string(t) + " out of range 0.." +
                    std::to_string(kMaxExchangeTag));
  }
  std::vector<std::vector<std::byte>> out(m);
  // Messages to this rank itself: matched by tag and copied.
  for (std::size_t i = 0; i < m; ++i) {
    if (peers[i] != rank_) continue;
    std::size_t j = 0;
    while (j < m && !(peers[j] == rank_ && tags[j] == recv_tags[i])) ++j;
    if (j == m)
      throw Error("Comm::exchange: rank " + std::to_string(rank_) + " expects a message from itself with tag " +
                  std::to_string(recv_tags[i]) + " but sends itself none");
    out[i] = sends[j];
  }
#if defined(LBDEM_HAVE_MPI)
  if (own_ == nullptr) return out;
  const MPI_Comm c = own_comm(own_);
  // Sizes first (tag 2t), then the bytes (tag 2t + 1).
  std::vector<std::uint64_t> send_sizes(m), recv_sizes(m);
  std::vector<MPI_Request> reqs;
  reqs.reserve(2 * m);
  for (std::size_t i = 0; i < m; ++i) {
    if (peers[i] == rank_) continue;
    reqs.emplace_back();
    LBDEM_MPI_CHECK(MPI_Irecv(&recv_sizes[i], 1, MPI_UINT64_T, peers[i], 2 * recv_tags[i], c, &reqs.back()));
  }
  for (std::size_t i = 0; i < m; ++i) {
    if (peers[i] == rank_) continue;
    send_sizes[i] = sends[i].size();
    reqs.emplace_back();
    LBDEM_MPI_CHECK(MPI_Isend(&send_sizes[i], 1, MPI_UINT64_T, peers[i], 2 * tags[i], c, &reqs.back()));
  }
  wait_all(reqs);
  for (std::size_t i = 0; i < m; ++i) {
    if (peers[i] == rank_) continue;
    out[i].resize(static_cast<std::size_t>(recv_sizes[i]));
    irecv_all(out[i].data(), out[i].size(), peers[i], 2 * recv_tags[i] + 1, c, reqs);
  }
  for (std::size_t i = 0; i < m; ++i) {
    if (peers[i] == rank_) continue;
    isend_all(sends[i].data(), sends[i].size(), peers[i], 2 * tags[i] + 1, c, reqs);
  }
  wait_all(reqs);
#endif
  return out;
}

void Comm::abort(int code) const {
#if defined(LBDEM_HAVE_MPI)
  if (size_ > 1) {
    // One line naming the rank that ends the job: MPI_Abort's own report is the launcher's and may be lost
    // or worded otherwise under another launcher (srun).
    std::fprintf(stderr, "lbdem: rank %d of %d stops every rank (exit code %d)\n", rank_, size_, code);
    std::fflush(stderr);
    MPI_Abort(MPI_COMM_WORLD, code);
    std::abort();  // MPI_Abort does not return; in case it does
  }
#endif
  std::exit(code);
}

}  // namespace lbdem::halo
