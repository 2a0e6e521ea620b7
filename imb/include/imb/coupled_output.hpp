// Snapshots of a coupled run in pieces (core/piece_output.hpp): every rank
// writes its owned box of the fields (density, velocity, solid fraction) and
// the particles it owns, with their hydrodynamic force, to its own files; rank
// 0 writes the XDMF index, a spatial collection of the pieces per step. No
// field or particle list is gathered; only the particle counts reach rank 0.
//
// Background (output.background): each rank packs its owned box of the
// fields on the device, in the precision the files store (float when they are
// written as fp32: 20 bytes per cell), into a buffer reserved at start, and
// brings it to page-locked host memory in one copy (imb/snapshot_pack.hpp);
// its writer thread writes from there while the run steps on, and the next
// snapshot waits for that write before it packs again. The thread owns every
// HDF5 call of the rank from the first snapshot on. On several ranks the
// particle counts are gathered when the copy is taken (collective), and rank
// 0 indexes a step once every rank has finished its pieces: at the next
// snapshot or at finish(), after each rank's wait and a barrier (the index
// never names an unfinished file). The files hold the same bytes either way.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/grid.hpp"
#include "core/memory_use.hpp"
#include "core/piece_output.hpp"

namespace lbdem::halo {
class Comm;
}
namespace lbdem::lbm {
class LbmSolver;
}
namespace lbdem::dem {
class DemSystem;
}
namespace lbdem::io {
class BackgroundWriter;
}

namespace lbdem::imb {

class CoupledSolver;
class SnapshotPack;

class CoupledSnapshots {
 public:
  struct Settings {
    std::string dir;           // the run's output folder
    bool fields_fp32 = false;  // fields stored as float32 (output.field_precision)
    bool background = false;   // output.background
    double dt = 1;             // seconds per step: the snapshots' times
  };
  // whole: the whole grid; pieces: every rank's owned box (index = rank).
  CoupledSnapshots(const Settings& s, const Grid& whole, std::vector<io::PieceBox> pieces, lbm::LbmSolver& fluid,
                   dem::DemSystem& dem, CoupledSolver& cs, const halo::Comm& comm);
  ~CoupledSnapshots();
  CoupledSnapshots(const CoupledSnapshots&) = delete;
  CoupledSnapshots& operator=(const CoupledSnapshots&) = delete;

  // A restart: the index keeps the snapshots of steps <= step.
  void resume(long step);
  // One snapshot of `step` (collective on several ranks).
  void write(long step);
  // Every background snapshot on disk and indexed; rethrows a failed write (collective). Nothing in the foreground.
  void finish();
  long count() const { return count_; }
  bool background() const { return static_cast<bool>(bg_); }
  // The largest host buffer of this rank's field output (values): the writer's slabs, and in the background the
  // piece's copy.
  std::size_t largest_buffer_values() const;
  // The device buffer the background snapshots hold (empty in the foreground).
  MemoryUse memory_use() const;
  // Wall time of the background snapshots (seconds, this rank): `take`, the
  // pack on the device, its copy to host and the particles' download, which
  // hold the run; `wait`, a snapshot held waiting for the previous one's
  // write (not finish()'s own wait); `write`, the writer thread's HDF5 writes
  // (beside the run). Complete after finish().
  struct Times {
    double take = 0, wait = 0, write = 0;
  };
  const Times& times() const { return times_; }

 private:
  struct Copy;
  void index_job(const std::shared_ptr<Copy>& snap);
  std::vector<long> gather_counts(long mine);

  Settings s_;
  lbm::LbmSolver& fluid_;
  dem::DemSystem& dem_;
  CoupledSolver& cs_;
  const halo::Comm& comm_;
  io::PieceParticleWriter pw_;
  io::PieceGridWriter gw_;
  std::vector<io::SlabField> fields_;
  long count_ = 0;
  std::shared_ptr<Copy> copy_;        // background: the step's particles for the thread
  std::unique_ptr<SnapshotPack> pack_;  // background: the piece's fields, reserved once
  Times times_;
  bool unindexed_ = false;            // several ranks: the copy's step written, not yet indexed
  std::unique_ptr<io::BackgroundWriter> bg_;  // declared last: its thread ends before what its jobs use goes
};

}  // namespace lbdem::imb
