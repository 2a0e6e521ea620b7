// Snapshots of a coupled run in pieces, in the foreground or by a writer thread (imb/coupled_output.hpp).
#include "imb/coupled_output.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <span>

#include "core/async_writer.hpp"
#include "core/memory_use.hpp"
#include "dem/particle_output.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "imb/coupled.hpp"
#include "imb/snapshot_pack.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

// What one background snapshot hands to the writer thread besides the
// fields, which lie in the SnapshotPack's host array (imb/snapshot_pack.hpp)
// until the next snapshot, which waits for this one's write first.
struct CoupledSnapshots::Copy {
  long step = 0;
  double time = 0;
  dem::HostParticles particles;
  std::vector<double> force;
  std::vector<long> counts;                        // particles per rank (rank 0)
  std::vector<std::pair<std::string, int>> names;  // the particle fields written (set by the job)
};

CoupledSnapshots::CoupledSnapshots(const Settings& s, const Grid& whole, std::vector<io::PieceBox> pieces,
                                   lbm::LbmSolver& fluid, dem::DemSystem& dem, CoupledSolver& cs, const halo::Comm& comm)
    : s_(s),
      fluid_(fluid),
      dem_(dem),
      cs_(cs),
      comm_(comm),
      pw_(s.dir, "particles", comm.rank(), comm.size()),
      gw_(s.dir, "fields", whole, std::move(pieces), comm.rank(), fluid.setup().domain.owned()),
      fields_{{"density", 1, "lattice"}, {"velocity", 3, "lattice (cells per step)"}, {"solid_fraction", 1, "1"}} {
  gw_.set_float32(s.fields_fp32);
  if (s.background) {
    // Reserved now, once: the device pack and the page-locked host array of
    // the owned box (coupled_memory counts the device part).
    pack_ = std::make_unique<SnapshotPack>(fluid.backend(), fluid.setup().domain.owned().size(), s.fields_fp32);
    bg_ = std::make_unique<io::BackgroundWriter>();
  }
}

CoupledSnapshots::~CoupledSnapshots() = default;

void CoupledSnapshots::resume(long step) {
  pw_.resume(step);
  gw_.resume(step);
}

std::size_t CoupledSnapshots::largest_buffer_values() const {
  return std::max(gw_.largest_buffer_values(), pack_ ? 5 * static_cast<std::size_t>(pack_->cells()) : std::size_t{0});
}

std::vector<long> CoupledSnapshots::gather_counts(long mine) {
  std::vector<long> counts{mine};
  if (!comm_.distributed()) return counts;
  const auto all = comm_.gather(std::as_bytes(std::span<const long>(&mine, 1)), 0);
  counts.clear();
  for (const auto& bytes : all) {
    long v = 0;
    std::memcpy(&v, bytes.data(), sizeof v);
    counts.push_back(v);
  }
  return counts;
}

// The index of `snap`'s step, on rank 0's writer thread after its pieces.
void CoupledSnapshots::index_job(const std::shared_ptr<Copy>& snap) {
  bg_->submit([this, snap] {
    gw_.index(snap->step, snap->time, fields_);
    pw_.index(snap->step, snap->time, snap->counts, snap->names);
  });
}

MemoryUse CoupledSnapshots::memory_use() const { return pack_ ? pack_->memory_use() : MemoryUse{}; }

void CoupledSnapshots::finish() {
  if (!bg_) return;
  bg_->wait();
  if (!comm_.distributed() || !unindexed_) return;
  comm_.barrier();
  if (comm_.root()) {
    index_job(copy_);
    bg_->wait();
  }
  unindexed_ = false;
}

void CoupledSnapshots::write(long step) {
  const double t = double(step) * s_.dt;
  const bool ranks = comm_.distributed();
  if (bg_) {  // one host copy of the piece at a time: the previous one written first
    const auto w0 = std::chrono::steady_clock::now();
    finish();
    times_.wait += seconds_since(w0);
  }
  if (comm_.root()) {  // every piece named in the manifest before any rank creates one
    gw_.record(step);
    pw_.record(step);
  }
  if (ranks) comm_.barrier();
  ++count_;
  const CellBox own = fluid_.setup().domain.owned();
  const Index slab = fluid_.output_slab_cells();
  // Where a slab starts in the owned box, x fastest: slabs are whole layers,
  // whole rows or one row piece of it, so each is contiguous there.
  auto offset = [own](const CellBox& b) {
    return static_cast<std::size_t>(((Index(b.lo[2] - own.lo[2]) * own.ext[1]) + (b.lo[1] - own.lo[1])) * own.ext[0] +
                                    (b.lo[0] - own.lo[0]));
  };
  if (!bg_) {
    const auto hf = cs_.hydro_force_host();
    const dem::HostParticles mine = dem_.download();
    const auto names = dem::write_particle_piece(pw_, step, t, mine, {{"hydrodynamic_force", 3, hf.data()}});
    gw_.write_piece(step, t, fields_, slab, [&](const CellBox& b, const std::vector<double*>& out) {
      fluid_.macroscopic_box(b, out[0], out[1]);
      cs_.solid_fraction_box(b, out[2]);
    });
    // The counts reach rank 0 after every rank wrote its pieces: the index never names an unfinished file.
    const std::vector<long> counts = gather_counts(static_cast<long>(mine.size()));
    if (comm_.root()) {
      gw_.index(step, t, fields_);
      pw_.index(step, t, counts, names);
    }
    return;
  }
  // Background: the owned box packed on the device and brought to the
  // pack's host array in one copy (the part that holds the run), then
  // written by the thread from there while the run steps on.
  const auto t0 = std::chrono::steady_clock::now();
  if (!copy_) copy_ = std::make_shared<Copy>();
  Copy& c = *copy_;
  c.step = step;
  c.time = t;
  c.force = cs_.hydro_force_host();
  c.particles = dem_.download();
  pack_->take(fluid_, cs_);
  c.counts = gather_counts(static_cast<long>(c.particles.size()));
  times_.take += seconds_since(t0);
  bg_->submit([this, snap = copy_, offset, slab, one = !ranks] {
    const auto w0 = std::chrono::steady_clock::now();
    snap->names = dem::write_particle_piece(pw_, snap->step, snap->time, snap->particles,
                                            {{"hydrodynamic_force", 3, snap->force.data()}});
    const auto M = static_cast<std::size_t>(pack_->cells());
    gw_.write_piece(snap->step, snap->time, fields_, slab, [&](const CellBox& b, const std::vector<double*>& out) {
      const std::size_t c0 = offset(b), m = static_cast<std::size_t>(b.size());
      if (pack_->fp32()) {  // float -> double -> float in the writer: the same bits
        const float* f = pack_->host_f();
        std::copy_n(f + c0, m, out[0]);
        std::copy_n(f + M + 3 * c0, 3 * m, out[1]);
        std::copy_n(f + 4 * M + c0, m, out[2]);
      } else {
        const double* d = pack_->host_d();
        std::copy_n(d + c0, m, out[0]);
        std::copy_n(d + M + 3 * c0, 3 * m, out[1]);
        std::copy_n(d + 4 * M + c0, m, out[2]);
      }
    });
    if (one) {  // one rank: its own pieces are all there is
      gw_.index(snap->step, snap->time, fields_);
      pw_.index(snap->step, snap->time, snap->counts, snap->names);
    }
    times_.write += seconds_since(w0);  // read by the caller only after wait()
  });
  unindexed_ = ranks;
}

}  // namespace lbdem::imb
