#pragma once
// SolverImpl<L, T>: the LBM solver for one lattice and storage precision.
// Included only by the per-combination kernel translation units.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/algorithms.hpp"
#include "core/buffer.hpp"
#include "lbm/dispatch.hpp"
#include "lbm/solver.hpp"
#include "population_stride.hpp"
#include "rest_state.hpp"

namespace lbdem::lbm {

// Incoming (unshifted) populations to a [q*cells + cell] array, for tests.
template <class L, class T, StreamKind S, int Parity>
struct PopulationKernel {
  PopView<T> src;
  GridView g;
  double* out;
  LBDEM_HD void operator()(Index cell, int x, int y, int z) const {
    const Neighbours nb = neighbours_at<L>(g, x, y, z);
    double f[L::Q];
    load_incoming<L, T, double, S, Parity>(src, nb, cell, f);
    LBDEM_UNROLL
    for (int q = 0; q < L::Q; ++q) out[q * g.n + cell] = f[q] + L::w(q);
  }
};

// Zeroes the Q population slots of each cell it is run on (T{} is the zero
// bit pattern of every storage type).
template <class L, class T>
struct ZeroPopulationsKernel {
  PopView<T> f;
  LBDEM_HD void operator()(Index cell, int, int, int) const {
    LBDEM_UNROLL
    for (int q = 0; q < L::Q; ++q) f.f[q * f.stride + cell] = T{};
  }
};

// Fills InitKernel's inputs for the cells of `box` (box x-fastest) with
// density r and velocity zero: a uniform state made on the device.
struct RestStateKernel {
  CellBox box;
  double* rho;
  double* u;
  double r;
  LBDEM_HD void operator()(Index, int x, int y, int z) const {
    const Index o = (x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]));
    rho[o] = r;
    u[3 * o] = u[3 * o + 1] = u[3 * o + 2] = 0.0;
  }
};

template <class L, class T>
class SolverImpl final : public LbmSolver, public RestStateInit {
  using R = compute_t<T>;  // the kernels' arithmetic type (lbm/storage.hpp)

 public:
  SolverImpl(const LbmSetup& s, Backend b) : s_(s), ex_(b) {
    g_ = s_.domain.view();
    owned_ = s_.domain.owned();
    stride_ = population_stride(g_.n);
    f0_ = Buffer<T>(b, stride_ * L::Q);
    if (s_.streaming == StreamKind::TwoLattice) f1_ = Buffer<T>(b, stride_ * L::Q);
    flags_ = Buffer<std::uint8_t>(b, g_.n);
    // Output and initial state pass through this buffer a slab at a time
    // (lbm_memory): reserved now, so that no output ever allocates.
    stage_ = Buffer<double>(b, 4 * lbm_stage_cells(s_));
    // First touch on the host: the owned cells' population pages are written
    // first by the loop and schedule that step them (for_each_cell_independent
    // over the owned box), so on a NUMA machine each page sits on the node of
    // the thread that streams it every step. The memsets that follow clear the
    // rest (ghost cells, padding) and leave placed pages where they are.
    if (!ex_.on_device()) {
      for_each_cell_independent(ex_, g_, owned_, ZeroPopulationsKernel<L, T>{PopView<T>{f0_.data(), stride_}});
      if (f1_.size())
        for_each_cell_independent(ex_, g_, owned_, ZeroPopulationsKernel<L, T>{PopView<T>{f1_.data(), stride_}});
    }
    flags_.fill_zero();
    f0_.fill_zero();
    if (f1_.size()) f1_.fill_zero();
    force_ = s_.body_force[0] != 0 || s_.body_force[1] != 0 || s_.body_force[2] != 0;
    const Relaxation rx = relaxation(s_.collision, s_.tau, s_.magic);
    omega_p_ = rx.omega_p;
    omega_m_ = rx.omega_m;
  }

  void initialize(const std::vector<std::uint8_t>& flags, const std::vector<double>& rho,
                  const std::vector<double>& u) override {
    const auto n = static_cast<std::size_t>(g_.n);
    if (flags.size() != n || rho.size() != n || u.size() != 3 * n)
      throw Error("LbmSolver::initialize: field sizes do not match the grid (" + std::to_string(n) + " cells)");
    set_flags(flags);
    // Slab by slab over every storage cell (ghosts included) through the staging buffer.
    const Index cap = stage_.size() / 4;
    std::vector<double> hr(static_cast<std::size_t>(cap)), hu(3 * static_cast<std::size_t>(cap));
    for (const CellBox& box : slabs_of(storage_box(), cap)) {
      const Index m = box.size();
      Index o = 0;
      for (int z = box.lo[2]; z < box.lo[2] + box.ext[2]; ++z)
        for (int y = box.lo[1]; y < box.lo[1] + box.ext[1]; ++y, o += box.ext[0]) {
          const auto c = static_cast<std::size_t>(g_.index(box.lo[0], y, z));
          std::copy_n(rho.begin() + static_cast<long>(c), box.ext[0], hr.begin() + o);
          std::copy_n(u.begin() + static_cast<long>(3 * c), 3 * box.ext[0], hu.begin() + 3 * o);
        }
      backend_copy_from_host(ex_.backend(), stage_.data(), hr.data(), static_cast<std::size_t>(m) * sizeof(double));
      backend_copy_from_host(ex_.backend(), stage_.data() + cap, hu.data(), 3 * static_cast<std::size_t>(m) * sizeof(double));
      init_box(box, cap);
      ex_.synchronize();  // the staging buffer is reused by the next slab
    }
    t_ = 0;
  }

  void initialize_at_rest(const std::vector<std::uint8_t>& flags, double rho,
                          const std::vector<CellBox>& unit_density) override {
    if (flags.size() != static_cast<std::size_t>(g_.n))
      throw Error("LbmSolver::initialize_at_rest: " + std::to_string(flags.size()) + " flags for " +
                  std::to_string(g_.n) + " cells");
    set_flags(flags);
    // The inputs initialize() would upload, made in the staging buffer on the
    // device; the fill and the equilibrium of a slab queue on one stream, so
    // the next slab's fill waits for them without a host synchronisation.
    const Index cap = stage_.size() / 4;
    auto at = [&](const CellBox& region, double r) {
      for (const CellBox& box : slabs_of(region, cap)) {
        for_each_cell(ex_, g_, box, RestStateKernel{box, stage_.data(), stage_.data() + cap, r});
        init_box(box, cap);
      }
    };
    at(storage_box(), rho);
    // A cell's equilibrium lands in slots that only it writes: writing the
    // unit-density cells again leaves the state initialize() makes.
    for (const CellBox& b : unit_density)
      if (!b.empty() && rho != 1.0) at(b, 1.0);
    ex_.synchronize();
    t_ = 0;
  }

  // Flags of every storage cell, checked against the case's boundary entries.
  void set_flags(const std::vector<std::uint8_t>& flags) {
    flags_.copy_from_host(flags);
    // Boundary handling is on when the case has boundary entries, the same
    // on every piece of a cut grid (a piece whose storage holds no wall runs
    // the same kernel as the whole grid). Ghost cells alone need none: the
    // step never reflects off them and updates only owned cells.
    has_bnd_ = s_.boundaries.count > 0;
    for (std::uint8_t v : flags)
      if (v != 0 && v != kGhostFlag && static_cast<int>(v) > s_.boundaries.count)
        throw Error("LbmSolver::initialize: cell flag " + std::to_string(v) + " names no boundary entry (the case has " +
                    std::to_string(s_.boundaries.count) + ")");
  }

  CellBox storage_box() const {
    CellBox all;
    all.ext[0] = g_.nx;
    all.ext[1] = g_.ny;
    all.ext[2] = g_.nz;
    return all;
  }

  // Equilibrium populations of the cells of `box` from the staging buffer's
  // density (first cap values) and velocity (from cap on).
  void init_box(const CellBox& box, Index cap) {
    const PopView<T> dst{f0_.data(), stride_};
    if (s_.streaming == StreamKind::AA)
      for_each_cell(ex_, g_, box, InitKernel<L, T, StreamKind::AA>{dst, g_, box, stage_.data(), stage_.data() + cap});
    else
      for_each_cell(ex_, g_, box,
                    InitKernel<L, T, StreamKind::TwoLattice>{dst, g_, box, stage_.data(), stage_.data() + cap});
  }

  void step(long n) override {
    for (long i = 0; i < n; ++i) {
      step_box(owned_);
      end_step();
    }
  }

  void step_box(const CellBox& box, Lane lane = Lane::Main) override {
    if (box.empty()) return;
    const Exec& ex = exec(lane);
    dispatch_step(s_.streaming, t_, has_bnd_, force_, [&](auto S, auto P, auto B, auto F) {
      run<decltype(S)::value, decltype(P)::value, decltype(B)::value, decltype(F)::value>(box, ex);
    });
  }

  void fork() override { lanes_.fork(ex_); }
  void join() override { lanes_.join(ex_); }
  const Exec& exec(Lane lane) const override { return lane == Lane::Edge ? lanes_.edge(ex_) : ex_; }

  void pack_halo(const HaloBlock& b, void* buf) override {
    if (b.box.empty() || b.slots == 0) return;
    const PopView<T> f{(b.second ? f1_ : f0_).data(), stride_};
    for_each(exec(Lane::Edge), b.box.size(), HaloPackKernel<T>{f, b, g_, static_cast<T*>(buf)});
  }
  void unpack_halo(const HaloBlock& b, const void* buf) override {
    if (b.box.empty() || b.slots == 0) return;
    const PopView<T> f{(b.second ? f1_ : f0_).data(), stride_};
    for_each(exec(Lane::Edge), b.box.size(),
             HaloUnpackKernel<T>{f, b, g_, flags_.data(), static_cast<const T*>(buf)});
  }
  int storage_bytes() const override { return static_cast<int>(sizeof(T)); }

  void end_step() override {
    if (s_.streaming == StreamKind::TwoLattice) f0_.swap(f1_);
    ++t_;
  }

  void macroscopic(std::vector<double>& rho, std::vector<double>& u) override {
    // Every storage cell; ghosts (never computed) stay 0.
    rho.assign(static_cast<std::size_t>(g_.n), 0.0);
    u.assign(3 * static_cast<std::size_t>(g_.n), 0.0);
    const Index cap = stage_.size() / 4;
    std::vector<double> hr(static_cast<std::size_t>(cap)), hu(3 * static_cast<std::size_t>(cap));
    for (const CellBox& box : slabs_of(owned_, cap)) {
      macroscopic_box(box, hr.data(), hu.data());
      Index o = 0;
      for (int z = box.lo[2]; z < box.lo[2] + box.ext[2]; ++z)
        for (int y = box.lo[1]; y < box.lo[1] + box.ext[1]; ++y, o += box.ext[0]) {
          const auto c = static_cast<std::size_t>(g_.index(box.lo[0], y, z));
          std::copy_n(hr.begin() + o, box.ext[0], rho.begin() + static_cast<long>(c));
          std::copy_n(hu.begin() + 3 * o, 3 * box.ext[0], u.begin() + static_cast<long>(3 * c));
        }
    }
  }

  void macroscopic_box(const CellBox& box, double* rho, double* u) override {
    const Index cap = stage_.size() / 4;
    for (int a = 0; a < 3; ++a)
      if (box.lo[a] < 0 || box.ext[a] < 0 || box.lo[a] + box.ext[a] > g_.extent(a))
        throw Error("LbmSolver::macroscopic_box: the box leaves the storage cells along axis " + std::to_string(a));
    if (box.size() > cap)
      throw Error("LbmSolver::macroscopic_box: a box of " + std::to_string(box.size()) +
                  " cells exceeds the output staging buffer of " + std::to_string(cap) + " cells");
    if (box.empty()) return;
    with_parity([&](auto S, auto P) {
      for_each_cell(ex_, g_, box,
                    MacroKernel<L, T, decltype(S)::value, decltype(P)::value>{
                        src_view(), g_, has_bnd_ ? flags_.data() : nullptr,
                        {s_.body_force[0], s_.body_force[1], s_.body_force[2]}, box, stage_.data(),
                        stage_.data() + cap});
    });
    ex_.synchronize();
    const auto m = static_cast<std::size_t>(box.size());
    backend_copy_to_host(ex_.backend(), rho, stage_.data(), m * sizeof(double));
    backend_copy_to_host(ex_.backend(), u, stage_.data() + cap, 3 * m * sizeof(double));
  }

  LbmDiagnostics diagnostics() override {
    Diag d;
    with_parity([&](auto S, auto P) {
      d = transform_reduce_cells(ex_, g_, owned_, Diag{}, DiagOp{},
                           DiagKernel<L, T, decltype(S)::value, decltype(P)::value>{
                               src_view(), g_, has_bnd_ ? flags_.data() : nullptr,
                               {s_.body_force[0], s_.body_force[1], s_.body_force[2]}},
                           scratch_);
    });
    LbmDiagnostics r;
    r.fluid_cells = static_cast<long>(d.fluid_cells);
    r.mass = static_cast<double>(d.fluid_cells) + d.mass_dev;
    for (int k = 0; k < 3; ++k) r.momentum[static_cast<std::size_t>(k)] = d.mom[k];
    r.max_speed = std::sqrt(d.u2max);
    r.finite = d.nan_cell < 0;
    auto xyz = [&](Index c) {
      int x = -1, y = -1, z = -1;
      if (c >= 0) g_.coords(c, x, y, z);
      return std::array<long, 3>{x, y, z};
    };
    r.max_speed_cell = xyz(d.u2max_cell);
    r.nonfinite_cell = xyz(d.nan_cell);
    return r;
  }

  std::vector<double> populations() override {
    Buffer<double> out(ex_.backend(), g_.n * L::Q);
    out.fill_zero();  // the kernel writes owned cells only; ghost cells read back as 0
    with_parity([&](auto S, auto P) {
      for_each_cell(ex_, g_, owned_,
                    PopulationKernel<L, T, decltype(S)::value, decltype(P)::value>{src_view(), g_, out.data()});
    });
    ex_.synchronize();
    return out.to_vector();
  }

  void synchronize() override { ex_.synchronize(); }
  long steps_done() const override { return t_; }
  std::size_t memory_bytes() const override { return memory_use().total(); }
  MemoryUse memory_use() const override {
    MemoryUse m;
    m.add("populations", f0_.bytes() + f1_.bytes());
    m.add("flags", flags_.bytes());
    m.add("output staging", stage_.bytes());
    return m;
  }
  const LbmSetup& setup() const override { return s_; }
  Backend backend() const override { return ex_.backend(); }
  double bytes_per_cell_step() const override { return 2.0 * L::Q * sizeof(T); }
  LbmRaw raw() override {
    LbmRaw r;
    r.src = f0_.data();
    r.dst = s_.streaming == StreamKind::AA ? f0_.data() : f1_.data();
    r.stride = stride_;
    r.grid = g_;
    r.owned = owned_;
    r.flags = flags_.data();
    // Boundary entries only: ghost cells stream as fluid, so a piece of a
    // periodic grid takes the kernels without flag reads. Coupling kernels
    // that run over whole tiles skip a piece's ghost cells by `owned`.
    r.has_boundaries = has_bnd_;
    r.step = t_;
    r.omega_p = omega_p_;
    r.omega_m = omega_m_;
    r.body_force = s_.body_force;
    r.boundaries = s_.boundaries;
    return r;
  }
  void commit_external_step() override {
    if (s_.streaming == StreamKind::TwoLattice) f0_.swap(f1_);
    ++t_;
  }
  void save_state(ckpt::Sink& out) override {
    ex_.synchronize();
    out.put<std::int32_t>(L::Q);
    out.put<std::int32_t>(static_cast<std::int32_t>(sizeof(T)));
    out.put<std::int32_t>(static_cast<std::int32_t>(s_.streaming));
    out.put<std::int64_t>(g_.n);
    out.put<std::int64_t>(stride_);
    out.put<std::int64_t>(t_);
    out.put_buffer(flags_);
    out.put_buffer(f0_);
    if (s_.streaming == StreamKind::TwoLattice) out.put_buffer(f1_);
  }
  void load_state(ckpt::Source& in) override {
    ex_.synchronize();
    in.expect<std::int32_t>(L::Q, "the lattice's velocity count Q");
    in.expect<std::int32_t>(static_cast<std::int32_t>(sizeof(T)), "the population precision (bytes)");
    in.expect<std::int32_t>(static_cast<std::int32_t>(s_.streaming), "the streaming scheme");
    in.expect<std::int64_t>(g_.n, "the grid's cell count");
    in.expect<std::int64_t>(stride_, "the population stride");
    const auto t = in.get<std::int64_t>();
    if (t < 0) in.mismatch("a negative step count");
    in.get_buffer(flags_);
    in.get_buffer(f0_);
    if (s_.streaming == StreamKind::TwoLattice) in.get_buffer(f1_);
    t_ = static_cast<long>(t);
    ex_.synchronize();
  }
  void read_slot(int q, void* host) override {
    check_slot(q);
    ex_.synchronize();
    f0_.copy_to_host(static_cast<T*>(host), g_.n, static_cast<Index>(q) * stride_);
  }
  void write_slot(int q, const void* host) override {
    check_slot(q);
    ex_.synchronize();
    f0_.copy_from_host(static_cast<const T*>(host), g_.n, static_cast<Index>(q) * stride_);
    ex_.synchronize();
  }
  void read_flags(std::uint8_t* host) override {
    ex_.synchronize();
    flags_.copy_to_host(host, g_.n);
  }
  void set_steps_done(long t) override {
    if (t < 0) throw Error("LbmSolver::set_steps_done: a negative step count " + std::to_string(t));
    t_ = t;
  }

 private:
  // Calls fn(scheme, parity of the next step) as integral constants (lbm/dispatch.hpp).
  template <class Fn>
  void with_parity(Fn&& fn) {
    dispatch_parity(s_.streaming, t_, fn);
  }

  void check_slot(int q) const {
    if (q < 0 || q >= L::Q)
      throw Error("LbmSolver: population slot " + std::to_string(q) + " is not one of 0.." + std::to_string(L::Q - 1));
  }

  PopView<T> src_view() const { return PopView<T>{f0_.data(), stride_}; }

  template <StreamKind S, int P, bool B, bool F>
  void run(const CellBox& box, const Exec& ex) {
    StepKernel<L, T, S, P, B, F> k;
    k.src = PopView<T>{f0_.data(), stride_};
    k.dst = S == StreamKind::AA ? k.src : PopView<T>{f1_.data(), stride_};
    k.g = g_;
    k.flags = flags_.data();
    k.bt = s_.boundaries;
    k.coll.omega_p = static_cast<R>(omega_p_);
    k.coll.omega_m = static_cast<R>(omega_m_);
    for (int a = 0; a < 3; ++a) k.coll.F[a] = static_cast<R>(s_.body_force[static_cast<std::size_t>(a)]);
    // Every population slot has one writer per step, and in place (A-A) the
    // cell that writes a slot is the one that read it: cells are independent.
    for_each_cell_independent(ex, g_, box, k);
  }

  LbmSetup s_;
  Exec ex_;
  Lanes lanes_;
  GridView g_;
  CellBox owned_;
  Index stride_ = 0;
  Buffer<T> f0_, f1_;
  Buffer<std::uint8_t> flags_;
  Buffer<double> stage_;  // output staging: rho [0, cap), u [cap, 4 cap)
  Scratch scratch_;
  bool has_bnd_ = false;
  bool force_ = false;
  double omega_p_ = 1, omega_m_ = 1;
  long t_ = 0;
};

}  // namespace lbdem::lbm
