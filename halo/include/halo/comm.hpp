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
#include <vector>

namespace lbdem::halo {

class Comm {
 public:
  // The world communicator. The first call initialises MPI when the process
  // was started by an MPI launcher (MPI_Init_thread, FUNNELED); MPI is
  // finalised at exit. Safe to call from anywhere, any number of times.
  static Comm& world();

  int rank() const { return rank_; }
  int size() const { return size_; }
  int local_rank() const { return local_rank_; }  // rank among the ranks of this node
  int local_size() const { return local_size_; }
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
  bool any(bool v) const;
  bool all(bool v) const { return !any(!v); }
  // (value, rank) of the largest value; ties go to the lowest rank.
  std::pair<double, int> maxloc(double v) const;

  // Root's bytes to every rank.
  void broadcast(std::vector<std::byte>& bytes, int root = 0) const;
  // Every rank's bytes, in rank order, on `root` (empty elsewhere).
  std::vector<std::vector<std::byte>> gather(std::span<const std::byte> mine, int root = 0) const;

  // Variable-size point-to-point exchange with several peers at once (host
  // memory): sends[i] goes to peers[i] with tags[i]; the message from
  // peers[i] with tag recv_tags[i] is returned in result[i]. Sizes need not
  // be known in advance. For particle migration and ghosts.
  std::vector<std::vector<std::byte>> exchange(std::span<const int> peers, std::span<const int> tags,
                                               std::span<const std::vector<std::byte>> sends,
                                               std::span<const int> recv_tags) const;

  // Ends every rank of the run (MPI_Abort) with `code`; a plain exit on one rank.
  [[noreturn]] void abort(int code) const;

  // The MPI_Comm (as an opaque handle) for the transports; nullptr without MPI.
  void* native() const { return native_; }
  // "mpi (4 ranks, 2 per node)" / "single rank (built without MPI)".
  std::string describe() const;

 private:
  Comm();
  int rank_ = 0, size_ = 1, local_rank_ = 0, local_size_ = 1;
  void* native_ = nullptr;
};

// True when this binary was built with MPI.
bool mpi_compiled();

}  // namespace lbdem::halo
