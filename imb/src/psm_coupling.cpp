#include "imb/psm_coupling.hpp"

#include <algorithm>
#include <cmath>

#include "psm_fused_impl.hpp"

namespace lbdem::imb {

void psm_step_d2q9(const Exec&, const lbm::LbmSetup&, const lbm::LbmRaw&, const CellSlotsView&, const SlotForceView&,
                   const PsmOptions&);
void psm_step_d3q19(const Exec&, const lbm::LbmSetup&, const lbm::LbmRaw&, const CellSlotsView&, const SlotForceView&,
                    const PsmOptions&);
void psm_fused_d2q9(const Exec&, const FusedArgs&);
void psm_fused_d3q19_f32(const Exec&, const FusedArgs&);
void psm_fused_d3q19_f64(const Exec&, const FusedArgs&);
// 16-bit storage (fp16s, fp16c), in their own translation units.
void psm_step_f16(const Exec&, const lbm::LbmSetup&, const lbm::LbmRaw&, const CellSlotsView&, const SlotForceView&,
                  const PsmOptions&);
void psm_fused_d2q9_f16(const Exec&, const FusedArgs&);
void psm_fused_d3q19_f16s(const Exec&, const FusedArgs&);
void psm_fused_d3q19_f16c(const Exec&, const FusedArgs&);

namespace {
bool sixteen_bit(lbm::Precision p) { return p == lbm::Precision::FP16S || p == lbm::Precision::FP16C; }
}  // namespace

void psm_fluid_step(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt) {
  if (sixteen_bit(s.precision)) psm_step_f16(ex, s, raw, slots, sf, opt);
  else if (s.lattice == lbm::LatticeKind::D2Q9) psm_step_d2q9(ex, s, raw, slots, sf, opt);
  else psm_step_d3q19(ex, s, raw, slots, sf, opt);
}

const char* to_string(PsmPipeline p) {
  switch (p) {
    case PsmPipeline::Auto: return "auto";
    case PsmPipeline::Fused: return "fused";
    case PsmPipeline::Mapped: return "mapped";
  }
  return "?";
}

PsmPipeline resolve_pipeline(const PsmOptions& o, int K, const std::string& slots_key) {
  if (o.pipeline == PsmPipeline::Mapped) return PsmPipeline::Mapped;
  std::string why;
  if (o.map.method == FractionMethod::Exact)
    why = "psm.fraction = exact (the exact overlap costs ~10 us per sphere: map it once with the mapped pipeline)";
  else if (o.map.table_in_constant)
    why = "psm.table_in_constant = true (the fused kernel reads the table from global memory)";
  else if (K > kFusedMaxSlots)
    why = slots_key + " (K) = " + std::to_string(K) + " > " + std::to_string(kFusedMaxSlots);
  if (why.empty()) return PsmPipeline::Fused;
  if (o.pipeline == PsmPipeline::Fused)
    throw ConfigError("psm.pipeline = fused does not apply with " + why + "; use psm.pipeline: mapped or auto");
  return PsmPipeline::Mapped;
}

PsmCoupling::PsmCoupling(lbm::LbmSolver& solver, int K)
    : solver_(solver), K_(K), ex_(solver.backend()) {
  if (K < 1) throw ConfigError("PSM slots per cell K = " + std::to_string(K) + ": must be >= 1");
  stage_ = Buffer<double>(solver.backend(), solver.output_slab_cells());
}

PsmCoupling::~PsmCoupling() = default;

CellSlots& PsmCoupling::mapped_slots() {
  if (!slots_) slots_ = std::make_unique<CellSlots>(solver_.backend(), grid(), K_);
  return *slots_;
}

const CellSlots& PsmCoupling::slots() const {
  if (!slots_) throw ConfigError("PsmCoupling::slots: no mapped-pipeline map has been made (psm.pipeline is fused)");
  return *slots_;
}

void PsmCoupling::map(const PsmParticles& p, const PsmOptions& opt, bool check_overflow) {
  const PsmPipeline before = pipeline_;
  pipeline_ = resolve_pipeline(opt, K_);
  if (pipeline_ == PsmPipeline::Fused) {
    if (!tiles_ || tiles_->capacity() != opt.tile_capacity)
      tiles_ = std::make_unique<TileMap>(solver_.backend(), grid(), K_, opt.tile_capacity);
    if (opt.map.method == FractionMethod::Table) {
      if (!opt.map.table) throw ConfigError("PSM: solid-fraction method 'table' needs a table (build_fraction_table)");
      if (opt.map.table->geometry.dim != grid().dim())
        throw ConfigError("PSM: the fraction table is " + std::to_string(opt.map.table->geometry.dim) +
                          "D but the grid is " + std::to_string(grid().dim()) + "D");
      if (ex_.on_device() && table_id_ != opt.map.table->id) {  // copied once per table, not per step
        table_.reserve_discard(solver_.backend(), static_cast<Index>(opt.map.table->values.size()));
        table_.copy_from_host(opt.map.table->values);
        table_id_ = opt.map.table->id;
      }
    }
    tiles_->build(ex_, p, opt.map.max_radius);
    if (before != pipeline_ || !parts_ready_) { parts_ = compute_parts(); parts_ready_ = true; }
  } else {
    if (before != pipeline_ || !parts_ready_) { parts_ = compute_parts(); parts_ready_ = true; }
    if (p.n == 0) return;
    mapped_slots().map(ex_, p, opt.map);
  }
  if (check_overflow) {
    const OverflowReport r = overflow();
    if (r.overflow || r.radius_too_large) throw ResourceError(r.message);
  }
}

void PsmCoupling::step(const PsmParticles& p, const PsmOptions& opt, const ForceOut& out) {
  if (p.n == 0) {  // no particles: the plain LBM kernel, no solid field read
    solver_.step(1);
    return;
  }
  for (const CellBox& b : parts_.outer) step_part(b, p, opt);
  step_part(parts_.inner, p, opt);
  finish_step(p, out);
}

namespace {
// The PSM step as the halo exchange's external step.
class PsmHaloStep final : public lbm::ExternalStep {
 public:
  PsmHaloStep(PsmCoupling& c, const PsmParticles& p, const PsmOptions& opt, const ForceOut& out)
      : c_(c), p_(p), opt_(opt), out_(out), parts_(c.parts()) {}
  void outer(lbm::Lane lane) override {
    for (const CellBox& b : parts_.outer) c_.step_part(b, p_, opt_, lane);
  }
  void inner(lbm::Lane lane) override { c_.step_part(parts_.inner, p_, opt_, lane); }
  void commit() override { c_.finish_step(p_, out_); }

 private:
  PsmCoupling& c_;
  const PsmParticles& p_;
  const PsmOptions& opt_;
  const ForceOut& out_;
  const PsmCoupling::Parts& parts_;
};
}  // namespace

void PsmCoupling::step(const PsmParticles& p, const PsmOptions& opt, const ForceOut& out, lbm::FluidHalo& halo) {
  if (p.n == 0) {
    halo.step(1);
    return;
  }
  PsmHaloStep ext(*this, p, opt, out);
  halo.begin_step(&ext);
  halo.finish_step();
}

PsmCoupling::Parts PsmCoupling::compute_parts() const {
  Parts r;
  if (pipeline_ != PsmPipeline::Fused) {
    r.outer = grid().outer(1);
    r.inner = grid().inner(1);
    return r;
  }
  // Tiles: the inner part is the tiles that hold no cell within one layer of
  // a cut; the outer parts are the rest of the tile grid, peeled axis by axis.
  const TileView tv = tiles_->view();
  const int nt[3] = {tv.ntx, tv.nty, tv.ntz};
  const int ts[3] = {tv.t.tx, tv.t.ty, tv.t.tz};
  CellBox all;
  for (int a = 0; a < 3; ++a) all.ext[a] = nt[a];
  CellBox in = all;
  const Grid& g = grid();
  for (int a = 0; a < 3; ++a) {
    if (!g.split[static_cast<std::size_t>(a)]) continue;
    const int lo = g.ghost_on(a), n = static_cast<int>(g.local[static_cast<std::size_t>(a)]);
    const int first = lo / ts[a] + 1;         // past the tile of the first owned layer
    const int last = (lo + n - 1) / ts[a] - 1;  // before the tile of the last owned layer
    in.lo[a] = first;
    in.ext[a] = last >= first ? last - first + 1 : 0;
  }
  if (in.empty()) {
    r.outer = {all};
    r.inner = CellBox{};
    return r;
  }
  CellBox rest = all;
  for (int a = 0; a < 3; ++a) {
    if (in.lo[a] == rest.lo[a] && in.ext[a] == rest.ext[a]) continue;
    CellBox lo = rest, hi = rest;
    lo.ext[a] = in.lo[a] - rest.lo[a];
    hi.lo[a] = in.lo[a] + in.ext[a];
    hi.ext[a] = rest.lo[a] + rest.ext[a] - hi.lo[a];
    if (!lo.empty()) r.outer.push_back(lo);
    if (!hi.empty()) r.outer.push_back(hi);
    rest.lo[a] = in.lo[a];
    rest.ext[a] = in.ext[a];
  }
  r.inner = in;
  return r;
}

void PsmCoupling::step_part(const CellBox& part, const PsmParticles& p, const PsmOptions& opt, lbm::Lane lane) {
  if (part.empty()) return;
  const PsmPipeline want = resolve_pipeline(opt, K_);
  if (want != pipeline_)
    throw ConfigError(std::string("PsmCoupling::step: the particles were mapped for the ") + to_string(pipeline_) +
                      " pipeline but the step asks for " + to_string(want) + " (call map() with the same options)");
  lbm::LbmRaw raw = solver_.raw();
  const Exec& ex = solver_.exec(lane);
  const int dim = solver_.setup().lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  if (pipeline_ == PsmPipeline::Fused) {
    FusedArgs a;
    a.setup = &solver_.setup();
    a.raw = &raw;
    a.tv = tiles_->view();
    a.tiles = part;
    a.p = p;
    a.opt = &opt;
    a.table = opt.map.method == FractionMethod::Table
                  ? (ex_.on_device() ? table_.data() : opt.map.table->values.data())
                  : nullptr;
    a.K = K_;
    const lbm::Precision pr = solver_.setup().precision;
    if (dim == 2) {
      if (sixteen_bit(pr)) psm_fused_d2q9_f16(ex, a);
      else psm_fused_d2q9(ex, a);
    } else {
      switch (pr) {
        case lbm::Precision::FP32: psm_fused_d3q19_f32(ex, a); break;
        case lbm::Precision::FP64: psm_fused_d3q19_f64(ex, a); break;
        case lbm::Precision::FP16S: psm_fused_d3q19_f16s(ex, a); break;
        case lbm::Precision::FP16C: psm_fused_d3q19_f16c(ex, a); break;
      }
    }
    return;
  }
  CellSlots& cs = mapped_slots();
  if (slot_forces_.size() == 0) {
    // Zeroed once: slots in ghost cells are never written (their cells belong
    // to another rank), so their share of a particle's force stays zero here.
    slot_forces_ = Buffer<double>(solver_.backend(), SlotForceView::kComponents * static_cast<Index>(K_) * raw.grid.n);
    slot_forces_.fill_zero();
    // Done before any queue's next work: this first part may run on the
    // halo's edge lane, which does not wait for the legacy default stream
    // (zeroing on a lane instead would race the other lane's part).
    ex_.synchronize();
  }
  const SlotForceView sf{slot_forces_.data(), raw.grid.n, K_};
  raw.owned = part;
  psm_fluid_step(ex, solver_.setup(), raw, cs.view(), sf, opt);
}

void PsmCoupling::finish_step(const PsmParticles& p, const ForceOut& out) {
  solver_.commit_external_step();
  if (!out.force) return;  // forces not wanted this step (e.g. a fixed particle between checks)
  if (pipeline_ == PsmPipeline::Fused) {
    tiles_->finish(ex_, p, out);
    return;
  }
  const int dim = solver_.setup().lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  const CellSlots& cs = *slots_;
  const SlotForceView sf{slot_forces_.data(), solver_.raw().grid.n, K_};
  psm_gather(ex_, cs.view(), sf, cs.pairs(), p, dim, out);
}

const CellSlots& PsmCoupling::output_slots(const PsmParticles& p, const PsmOptions& opt) {
  if (pipeline_ == PsmPipeline::Fused || !slots_) {
    MapOptions m = opt.map;
    m.keep_overflow = false;
    mapped_slots().map(ex_, p, m);  // output only: not in the time loop's path
  }
  return *slots_;
}

void PsmCoupling::solid_fraction_device(const PsmParticles& p, const PsmOptions& opt, const CellBox& box,
                                        double* out) {
  if (box.empty()) return;
  if (pipeline_ == PsmPipeline::Fused && tiles_) {
    const float* values = nullptr;
    if (opt.map.method == FractionMethod::Table && opt.map.table)
      values = ex_.on_device() ? table_.data() : opt.map.table->values.data();
    tiles_->total_eps(ex_, p, opt.map.method, opt.map.table, values, opt.map.linear_normalised, box, out);
  } else if (slots_ && p.n > 0) {
    slots_->total_eps_box(ex_, box, out);
  } else {  // nothing mapped: no solid
    backend_memset(ex_.backend(), out, 0, static_cast<std::size_t>(box.size()) * sizeof(double));
  }
}

void PsmCoupling::solid_fraction_box(const PsmParticles& p, const PsmOptions& opt, const CellBox& box, double* eps) {
  if (box.empty()) return;
  if (box.size() > stage_.size())
    throw Error("PsmCoupling::solid_fraction_box: a box of " + std::to_string(box.size()) +
                " cells exceeds the output staging buffer of " + std::to_string(stage_.size()) + " cells");
  const auto m = static_cast<std::size_t>(box.size());
  solid_fraction_device(p, opt, box, stage_.data());
  ex_.synchronize();
  backend_copy_to_host(ex_.backend(), eps, stage_.data(), m * sizeof(double));
}

MemoryUse PsmCoupling::memory_use() const {
  MemoryUse m;
  if (tiles_) m.add(tiles_->memory_use());
  if (slots_) m.add(slots_->memory_use());
  if (slot_forces_.size()) m.add("slot forces", slot_forces_.bytes());
  if (table_.size()) m.add("fraction table", table_.bytes());
  m.add("output staging", stage_.bytes());
  MemoryUse r;  // zero-byte components dropped (as psm_memory)
  for (const auto& it : m.items)
    if (it.bytes > 0) r.add(it.name, it.bytes);
  return r;
}

namespace {
// Floats of the default fraction table (build_fraction_table's node counts:
// 3D 32 x 11 x 11, 2D 64 x 32, two coefficients a node).
std::size_t fraction_table_values(int dim) {
  TableGeometry g;
  g.dim = dim;
  g.nt = dim == 3 ? 32 : 64;
  g.nu = dim == 3 ? 11 : 32;
  g.nv = dim == 3 ? 11 : 1;
  return static_cast<std::size_t>(g.floats());
}
}  // namespace

MemoryUse psm_memory(const lbm::LbmSetup& s, int K, const PsmOptions& opt, Index particles, bool device) {
  const GridView g = s.domain.view();
  const int dim = s.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  const auto n = static_cast<std::size_t>(g.n);
  const auto np = static_cast<std::size_t>(particles);
  const int B = static_cast<int>(std::floor(2.0 * std::max(opt.map.max_radius, 0.0))) + 2;
  const std::size_t table_bytes =
      opt.map.method == FractionMethod::Table ? (opt.map.table ? opt.map.table->values.size() : fraction_table_values(dim)) *
                                                    sizeof(float)
                                              : 0;
  constexpr std::size_t kLog = 1024;  // overflow log entries (TileMap, CellSlots defaults)
  MemoryUse m;
  if (resolve_pipeline(opt, K) == PsmPipeline::Fused) {
    const TileShape t = TileShape::for_dim(dim);
    auto tiles_on = [](Index cells, int T) { return static_cast<std::size_t>((cells + T - 1) / T); };
    const std::size_t tiles = tiles_on(g.nx, t.tx) * tiles_on(g.ny, t.ty) * tiles_on(g.nz, t.tz);
    const auto cap = static_cast<std::size_t>(opt.tile_capacity);
    m.add("tile lists", tiles * sizeof(int) + 2 * tiles * cap * sizeof(int));
    const std::size_t max_tiles = static_cast<std::size_t>(2 + (B - 1) / t.tx) * static_cast<std::size_t>(2 + (B - 1) / t.ty) *
                                  (dim == 3 ? static_cast<std::size_t>(2 + (B - 1) / t.tz) : 1);
    m.add("tile partial forces", np * max_tiles * 6 * sizeof(double));
    m.add("overflow logs", 4 * sizeof(int) + 2 * kLog * (sizeof(Index) + sizeof(int)));
    if (device) m.add("fraction table", table_bytes);
  } else if (np > 0) {
    const auto k = static_cast<std::size_t>(K);
    m.add("cell slots", n * (sizeof(int) + k * (sizeof(int) + sizeof(double) + 3 * sizeof(float))));
    m.add("slot pairs", np * static_cast<std::size_t>(dim == 3 ? B * B * B : B * B) * sizeof(int));
    m.add("overflow logs", 4 * sizeof(int) + kLog * (sizeof(Index) + sizeof(int)));
    if (device && !opt.map.table_in_constant) m.add("fraction table", table_bytes);
    if (opt.map.method == FractionMethod::Exact && opt.map.defer_exact) {
      const double rmax = std::max(opt.map.max_radius, 0.0);
      const double ro = rmax + std::sqrt(static_cast<double>(dim)), ri = std::max(rmax - std::sqrt(double(dim)), 0.0);
      const double shell = dim == 3 ? 4.0 / 3.0 * M_PI * (ro * ro * ro - ri * ri * ri) : M_PI * (ro * ro - ri * ri);
      m.add("exact queue", np * static_cast<std::size_t>(std::ceil(shell)) * sizeof(Index));
    }
    m.add("slot forces", static_cast<std::size_t>(SlotForceView::kComponents) * k * n * sizeof(double));
  }
  m.add("output staging", static_cast<std::size_t>(lbm::lbm_stage_cells(s)) * sizeof(double));
  MemoryUse r;
  for (const auto& it : m.items)
    if (it.bytes > 0) r.add(it.name, it.bytes);
  return r;
}

std::vector<double> PsmCoupling::solid_fraction_host(const PsmParticles& p, const PsmOptions& opt) {
  return output_slots(p, opt).total_eps_host();
}

OverflowReport PsmCoupling::overflow() const {
  if (pipeline_ == PsmPipeline::Fused) return tiles_->overflow();
  if (!slots_) return OverflowReport{};
  return slots_->overflow();
}

void PsmCoupling::clear_overflow() {
  if (tiles_) tiles_->clear_overflow(ex_);
  if (slots_) slots_->clear_overflow(ex_);
}

}  // namespace lbdem::imb
