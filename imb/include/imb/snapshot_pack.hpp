// A coupled snapshot's fields taken off the device in one piece, for the
// background writer (imb/coupled_output.hpp). The rank's owned box of density
// (M values), velocity (3M) and solid fraction (M), x fastest, is packed on
// the device into one buffer in the precision the files store (float for
// fp32 files: 20 B per cell; double: 40 B), then copied in one transfer into
// page-locked host memory, from which the writer thread writes while the run
// steps on. Both buffers are reserved once, at construction; a snapshot
// allocates nothing. On the host backend the pack is made straight in the
// host array (no second copy).
//
// The values are those of the foreground path bit for bit: density and
// velocity by lbm::MacroKernel's own arithmetic for each cell, the solid
// fraction by the coupling's solid_fraction_device (what its staged
// solid_fraction_box reads), each rounded to float once, as the writer rounds.
#pragma once

#include <cstddef>

#include "core/exec.hpp"
#include "core/grid.hpp"
#include "core/memory_use.hpp"

namespace lbdem::lbm {
class LbmSolver;
}

namespace lbdem::imb {

class CoupledSolver;

class SnapshotPack {
 public:
  // cells: the owned box's cell count; fp32: the files store float32.
  SnapshotPack(Backend b, Index cells, bool fp32);
  ~SnapshotPack();
  SnapshotPack(const SnapshotPack&) = delete;
  SnapshotPack& operator=(const SnapshotPack&) = delete;

  // Bytes a pack of `cells` cells reserves on the device (0 on the host
  // backend) and in host memory (page-locked on the device backend).
  static std::size_t device_bytes(Backend b, Index cells, bool fp32);
  static std::size_t host_bytes(Index cells, bool fp32);

  // Packs the fields of the fluid's owned box at its current step, with the
  // coupling's solid fraction at the particles' current positions, and
  // brings them to host memory. Synchronous: returns with the host array
  // complete (the run's queue is drained).
  void take(lbm::LbmSolver& fluid, CoupledSolver& cs);

  Index cells() const { return cells_; }
  bool fp32() const { return fp32_; }
  // The host array of 5 cells() values: density, velocity (3 per cell), solid
  // fraction. host_f() when fp32(), else host_d().
  const float* host_f() const { return static_cast<const float*>(host_); }
  const double* host_d() const { return static_cast<const double*>(host_); }
  // The device buffer ("snapshot pack (output.background)"), empty on the host backend.
  MemoryUse memory_use() const;

 private:
  Backend backend_;
  Index cells_;
  bool fp32_;
  void* device_ = nullptr;  // device backend: the pack; host backend: null (the pack is host_)
  void* host_ = nullptr;    // page-locked (device backend) or 64-byte aligned (host backend)
};

}  // namespace lbdem::imb
