#pragma once
// The ranks of a run. Built with MPI and started under mpirun/srun, Comm::world()
// spans all ranks; otherwise (no MPI in the build, or a plain `lbdem run`) it is
// one rank and every collective is the identity. The physics modules never see
// MPI: they talk to neighbours through halo::Transport (transport.hpp) and
// reduce through the collectives here.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace lbdem::halo {

class Comm {
 public:
  // The world communicator. The first call initialises MPI when the process
  // was started by an MPI launcher (MPI_Init_thread, FUNNELED; the launcher is
  // recognised by its environment: OMPI_COMM_WORLD_SIZE, PMI_SIZE, PMIX_RANK,
  // MV2_COMM_WORLD_SIZE, ...; LBDEM_MPI=1 forces MPI, LBDEM_MPI=0 keeps it off);
  // MPI is finalised at exit. Safe to call from anywhere, any number of times.
  // Every collective below must be called by all ranks in the same order.
  static Comm& world();

  int rank() const { return rank_; }
  int size() const { return size_; }
  int local_rank() const { return local_rank_; }  // rank among the ranks of this node
  int local_size() const { return local_size_; }
  // The lowest rank on this rank's node: equal exactly for the ranks of one node.
  int node() const { return node_; }
  bool distributed() const { return size_ > 1; }
  bool root() const { return rank_ == 0; }

  void barrier() const;
  // Reductions over all ranks; every rank gets the result. Sums of doubles
  // are done in a fixed order (rank 0, 1, ...), so a given rank count always
  // gives the same bits.
  double sum(double v) const;
  long sum(long v) const;
  void sum(std::span<double> v) const;  // element-wise, in place
  double max(double v) const;
  double min(double v) const;
  long max(long v) const;
  long min(long v) const;
  bool any(bool v) const;
  bool all(bool v) const { return !any(!v); }
  // (value, rank) of the largest value; ties go to the lowest rank.
  std::pair<double, int> maxloc(double v) const;

  // Root's bytes to every rank.
  void broadcast(std::vector<std::byte>& bytes, int root = 0) const;
  // Every rank's bytes, in rank order, on `root` (empty elsewhere).
  std::vector<std::vector<std::byte>> gather(std::span<const std::byte> mine, int root = 0) const;
  // Every rank's bytes, in rank order, on every rank.
  std::vector<std::vector<std::byte>> allgather(std::span<const std::byte> mine) const;

  // Variable-size point-to-point exchange with several peers at once (host
  // memory): sends[i] goes to peers[i] with tags[i]; the message from
  // peers[i] with tag recv_tags[i] is returned in result[i]. Sizes need not
  // be known in advance. For particle migration and ghosts. A peer may be
  // this rank (copied locally). Each (peer, tag) is sent at most once; tags
  // are 0..16000. Blocking: returns when every message has arrived.
  std::vector<std::vector<std::byte>> exchange(std::span<const int> peers, std::span<const int> tags,
                                               std::span<const std::vector<std::byte>> sends,
                                               std::span<const int> recv_tags) const;

  // Ends every rank of the run (MPI_Abort) with `code`; a plain exit on one rank.
  [[noreturn]] void abort(int code) const;

  // The MPI_Comm (as an opaque handle, `*static_cast<MPI_Comm*>(native())`)
  // for the transports: a duplicate of MPI_COMM_WORLD, so their tags never
  // meet the messages of the collectives here. nullptr without MPI.
  void* native() const { return native_; }
  // "mpi (4 ranks, 2 on this node)", "mpi (1 rank)", "single rank (built without MPI)",
  // "single rank (not started by an MPI launcher)".
  std::string describe() const;

 private:
  Comm();
  ~Comm();
  Comm(const Comm&) = delete;
  Comm& operator=(const Comm&) = delete;
  int rank_ = 0, size_ = 1, local_rank_ = 0, local_size_ = 1, node_ = 0;
  void* native_ = nullptr;  // MPI_Comm* for the transports
  void* own_ = nullptr;     // MPI_Comm* for the collectives and exchange() here
  std::string why_single_;  // why this is one rank without MPI ("" under MPI)
  bool owns_mpi_ = false;   // MPI_Init was called here, so MPI_Finalize is too
};

// True when this binary was built with MPI.
bool mpi_compiled();

}  // namespace lbdem::halo
