// Snapshots of a coupled run in pieces, in the foreground or by a writer thread (imb/coupled_output.hpp).
#include "imb/coupled_output.hpp"

#include <algorithm>
#include <cstring>
#include <span>

#include "core/async_writer.hpp"
#include "core/memory_use.hpp"
#include "dem/particle_output.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "imb/coupled.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// The piece's host copy of one background snapshot. The fields lie in one
// array per precision, x fastest over the owned box: density (M), velocity
// (3M), solid fraction (M). In float only when the files store float: the
// double -> float rounding is then the one the writer would do, so the bytes
// on disk are those of the foreground path.
struct CoupledSnapshots::Copy {
  long step = 0;
  double time = 0;
  dem::HostParticles particles;
  std::vector<double> force;
  std::vector<long> counts;                        // particles per rank (rank 0)
  std::vector<std::pair<std::string, int>> names;  // the particle fields written (set by the job)
  std::size_t cells = 0;                           // M
  std::unique_ptr<float[]> f;                      // 5M values (fp32 files)
  std::unique_ptr<double[]> d;                     // 5M values (fp64 files)
  std::vector<double> stage;                       // fp32: one slab of the three fields in double
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
  if (s.background) bg_ = std::make_unique<io::BackgroundWriter>();
}

CoupledSnapshots::~CoupledSnapshots() = default;

void CoupledSnapshots::resume(long step) {
  pw_.resume(step);
  gw_.resume(step);
}

std::size_t CoupledSnapshots::largest_buffer_values() const {
  return std::max(gw_.largest_buffer_values(), copy_ ? 5 * copy_->cells + copy_->stage.size() : std::size_t{0});
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
  if (bg_) finish();  // one host copy of the piece at a time
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
  // Background: the piece copied out slab by slab (x fastest, the order of
  // the writer's slabs) into the kept buffers, then handed to the thread.
  if (!copy_) copy_ = std::make_shared<Copy>();
  Copy& c = *copy_;
  const auto M = static_cast<std::size_t>(own.size());
  if (c.cells != M) {  // first snapshot: allocated once, not zero-filled (every value is written below)
    c.cells = M;
    if (s_.fields_fp32) {
      c.f = std::make_unique_for_overwrite<float[]>(5 * M);
      c.stage.resize(5 * static_cast<std::size_t>(std::min<Index>(slab, own.size())));
    } else {
      c.d = std::make_unique_for_overwrite<double[]>(5 * M);
    }
  }
  c.step = step;
  c.time = t;
  c.force = cs_.hydro_force_host();
  c.particles = dem_.download();
  for (const CellBox& b : slabs_of(own, slab)) {
    const std::size_t c0 = offset(b), m = static_cast<std::size_t>(b.size());
    if (s_.fields_fp32) {
      double* rho = c.stage.data();
      double* u = rho + m;
      double* eps = u + 3 * m;
      fluid_.macroscopic_box(b, rho, u);
      cs_.solid_fraction_box(b, eps);
      std::copy_n(rho, m, c.f.get() + c0);  // double -> float: the writer's own rounding
      std::copy_n(u, 3 * m, c.f.get() + M + 3 * c0);
      std::copy_n(eps, m, c.f.get() + 4 * M + c0);
    } else {
      fluid_.macroscopic_box(b, c.d.get() + c0, c.d.get() + M + 3 * c0);
      cs_.solid_fraction_box(b, c.d.get() + 4 * M + c0);
    }
  }
  c.counts = gather_counts(static_cast<long>(c.particles.size()));
  bg_->submit([this, snap = copy_, offset, slab, one = !ranks] {
    snap->names = dem::write_particle_piece(pw_, snap->step, snap->time, snap->particles,
                                            {{"hydrodynamic_force", 3, snap->force.data()}});
    const std::size_t M = snap->cells;
    gw_.write_piece(snap->step, snap->time, fields_, slab, [&](const CellBox& b, const std::vector<double*>& out) {
      const std::size_t c0 = offset(b), m = static_cast<std::size_t>(b.size());
      if (snap->f) {  // float -> double -> float in the writer: the same bits
        std::copy_n(snap->f.get() + c0, m, out[0]);
        std::copy_n(snap->f.get() + M + 3 * c0, 3 * m, out[1]);
        std::copy_n(snap->f.get() + 4 * M + c0, m, out[2]);
      } else {
        std::copy_n(snap->d.get() + c0, m, out[0]);
        std::copy_n(snap->d.get() + M + 3 * c0, 3 * m, out[1]);
        std::copy_n(snap->d.get() + 4 * M + c0, m, out[2]);
      }
    });
    if (one) {  // one rank: its own pieces are all there is
      gw_.index(snap->step, snap->time, fields_);
      pw_.index(snap->step, snap->time, snap->counts, snap->names);
    }
  });
  unindexed_ = ranks;
}

}  // namespace lbdem::imb
