#pragma once
// The fluid halo exchange of one rank: which population slots cross each face
// and edge of its piece, packed into one message per neighbour, and the step
// that overlaps sending them with the update of the inner cells.
//
// The rules (halo/README.md, proven by tests/lbm/test_ghost_layers.cpp):
//  * Two-lattice (pull): after every step the ghost cells receive the new
//    populations of their images that the owned cells will pull: across the
//    face towards -x, the slots with c_x = +1 (5 of 19 in D3Q19, 3 of 9 in
//    D2Q9); across an edge, the one slot whose velocity points along it.
//  * A-A: after an even step the ghost cells receive the slots the odd step
//    will read (the opposite ones: c_x = -1 on that face); after an odd step
//    the slots that owned fluid cells wrote into ghost cells go back to the
//    image cells (the same slot set), masked so that only slots written by
//    the sender's fluid cells are taken.
//  * Ghost copies of boundary cells are never exchanged.
// One step: the outer slabs on the Edge lane, pack, start the transport, the
// inner box on the Main lane, finish, unpack on the Edge lane, join.
#include <array>
#include <memory>
#include <vector>

#include "core/buffer.hpp"
#include "halo/decomposition.hpp"
#include "halo/transport.hpp"
#include "lbm/solver.hpp"

namespace lbdem::lbm {

// One neighbour region of a piece: direction r (-1, 0, +1 per axis; non-zero
// only on split axes), its peer, and the blocks for each phase.
struct HaloLink {
  std::array<int, 3> dir{0, 0, 0};
  int peer = -1;
  int tag = 0;       // index of dir in [0, 27)
  int recv_tag = 0;  // index of -dir
  // send: the owned layer facing dir (fill) or the ghost region dir (write-back);
  // recv: the ghost region dir (fill) or the owned layer facing dir (write-back).
  HaloBlock send_fill_tl, send_fill_aa, send_back, recv_fill_tl, recv_fill_aa, recv_back;
};

// The links of `rank`'s piece for lattice `kind` (directions with no slot,
// such as D3Q19's corners, and directions off a walled end are left out).
std::vector<HaloLink> halo_links(const halo::Decomposition& dec, int rank, const Grid& piece, LatticeKind kind);

// Wall-clock split of the steps since the last reset (seconds).
struct HaloTimes {
  long steps = 0;
  double total = 0;    // whole steps
  double start = 0;    // in transport start() (staging copies wait for the edge work)
  double finish = 0;   // in transport finish(): communication not hidden by the inner update
  std::size_t bytes_per_step = 0;  // sent by this rank
  int messages = 0;                // per exchange
};

// A step computed by another module on the solver's populations (imb/: the
// PSM step), in the parts the exchange overlaps: outer() updates every owned
// cell next to a cut (and may update more), inner() the rest, commit() ends
// the step (LbmSolver::commit_external_step and whatever follows it).
class ExternalStep {
 public:
  virtual ~ExternalStep() = default;
  virtual void outer(Lane lane) = 0;
  virtual void inner(Lane lane) = 0;
  virtual void commit() = 0;
};

class FluidHalo {
 public:
  // The solver's grid must be `dec.piece(whole, rank)`. The transport is bound
  // here (buffers allocated once) and must outlive this object.
  FluidHalo(LbmSolver& solver, const halo::Decomposition& dec, int rank, halo::Transport& transport);

  // Ghost cells of the incoming populations from their images: once after
  // initialize() (the two-lattice step pulls from them; no-op for A-A, whose
  // next step after initialize is even).
  void fill() {
    begin_fill();
    finish_fill();
  }
  void begin_fill();
  void finish_fill();
  // One step in two halves (several ranks in one process: all begin, then all
  // finish), or n whole steps.
  // `ext`: the step is computed by ext (its parts) instead of the solver's own kernel.
  void begin_step(ExternalStep* ext = nullptr);
  void finish_step();
  void step(long n);
  // How a step is ordered (benchmarks compare them to measure how much
  // communication the overlap hides):
  enum class Mode {
    Overlap,      // outer, pack, start, inner, finish, unpack (the default)
    Serial,       // whole step, then pack, start, finish, unpack
    ComputeOnly,  // the overlapped step's kernels without any exchange (wrong physics: timing only)
  };
  void set_mode(Mode m) { mode_ = m; }

  const HaloTimes& times() const { return times_; }
  void reset_times() { times_ = HaloTimes{}; times_.bytes_per_step = bytes_; times_.messages = messages_; }
  const std::vector<HaloLink>& links() const { return links_; }

 private:
  enum class Phase { None, FillTwoLattice, FillAA, WriteBack };
  Phase phase_of_step() const;
  void pack(Phase ph);
  void unpack(Phase ph);

  LbmSolver& s_;
  halo::Transport& tr_;
  std::vector<HaloLink> links_;
  std::vector<Buffer<std::byte>> send_, recv_;
  std::vector<CellBox> outer_;
  CellBox inner_, owned_;
  Mode mode_ = Mode::Overlap;
  bool in_step_ = false;
  ExternalStep* ext_ = nullptr;
  Phase phase_ = Phase::None;
  double t_begin_ = 0;
  std::size_t bytes_ = 0;
  int messages_ = 0;
  HaloTimes times_;
};

// The piece of whole-grid fields (flags, rho, u as LbmSolver::initialize takes
// them) that `piece` stores: images on split axes (wrapped where periodic);
// a ghost whose image is fluid becomes kGhostFlag, one whose image is a
// boundary keeps its flag, one beyond a walled end is kGhostFlag at rest.
void piece_fields(const Grid& whole, const Grid& piece, const std::vector<std::uint8_t>& flags,
                  const std::vector<double>& rho, const std::vector<double>& u, std::vector<std::uint8_t>& pflags,
                  std::vector<double>& prho, std::vector<double>& pu);

// The owned cells of a piece's field (c components per cell) placed into the
// whole grid's field.
void place_piece(const Grid& whole, const Grid& piece, int c, const std::vector<double>& part, std::vector<double>& out);

}  // namespace lbdem::lbm
