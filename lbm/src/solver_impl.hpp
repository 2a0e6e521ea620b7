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

template <class L, class T>
class SolverImpl final : public LbmSolver {
 public:
  SolverImpl(const LbmSetup& s, Backend b) : s_(s), ex_(b) {
    g_ = s_.domain.view();
    owned_ = s_.domain.owned();
    stride_ = (g_.n + 63) / 64 * 64;
    f0_ = Buffer<T>(b, stride_ * L::Q);
    if (s_.streaming == StreamKind::TwoLattice) f1_ = Buffer<T>(b, stride_ * L::Q);
    flags_ = Buffer<std::uint8_t>(b, g_.n);
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
    ensure_macro_buffers();
    rho_d_.copy_from_host(rho);
    u_d_.copy_from_host(u);
    const PopView<T> dst{f0_.data(), stride_};
    if (s_.streaming == StreamKind::AA)
      for_each(ex_, g_.n, InitKernel<L, T, StreamKind::AA>{dst, g_, rho_d_.data(), u_d_.data()});
    else
      for_each(ex_, g_.n, InitKernel<L, T, StreamKind::TwoLattice>{dst, g_, rho_d_.data(), u_d_.data()});
    t_ = 0;
    ex_.synchronize();
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
    ensure_macro_buffers();
    with_parity([&](auto S, auto P) {
      for_each_cell(ex_, g_, owned_,
               MacroKernel<L, T, decltype(S)::value, decltype(P)::value>{
                   src_view(), g_, has_bnd_ ? flags_.data() : nullptr,
                   {s_.body_force[0], s_.body_force[1], s_.body_force[2]}, rho_d_.data(), u_d_.data()});
    });
    ex_.synchronize();
    rho = rho_d_.to_vector();
    u = u_d_.to_vector();
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
    with_parity([&](auto S, auto P) {
      for_each_cell(ex_, g_, owned_,
                    PopulationKernel<L, T, decltype(S)::value, decltype(P)::value>{src_view(), g_, out.data()});
    });
    ex_.synchronize();
    return out.to_vector();
  }

  void synchronize() override { ex_.synchronize(); }
  long steps_done() const override { return t_; }
  std::size_t memory_bytes() const override {
    return f0_.bytes() + f1_.bytes() + flags_.bytes() + rho_d_.bytes() + u_d_.bytes();
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
    // Coupling kernels that run over whole tiles skip the ghost cells of a
    // piece by their flag.
    r.has_boundaries = has_bnd_ || !s_.domain.whole_grid();
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

 private:
  // Calls fn(scheme, parity of the next step) as integral constants (lbm/dispatch.hpp).
  template <class Fn>
  void with_parity(Fn&& fn) {
    dispatch_parity(s_.streaming, t_, fn);
  }

  PopView<T> src_view() const { return PopView<T>{f0_.data(), stride_}; }

  void ensure_macro_buffers() {
    // Zeroed once: cells outside the owned box (ghosts) are never written.
    if (rho_d_.size() != g_.n) {
      rho_d_ = Buffer<double>(ex_.backend(), g_.n);
      rho_d_.fill_zero();
    }
    if (u_d_.size() != 3 * g_.n) {
      u_d_ = Buffer<double>(ex_.backend(), 3 * g_.n);
      u_d_.fill_zero();
    }
  }

  template <StreamKind S, int P, bool B, bool F>
  void run(const CellBox& box, const Exec& ex) {
    StepKernel<L, T, S, P, B, F> k;
    k.src = PopView<T>{f0_.data(), stride_};
    k.dst = S == StreamKind::AA ? k.src : PopView<T>{f1_.data(), stride_};
    k.g = g_;
    k.flags = flags_.data();
    k.bt = s_.boundaries;
    k.coll.omega_p = static_cast<T>(omega_p_);
    k.coll.omega_m = static_cast<T>(omega_m_);
    for (int a = 0; a < 3; ++a) k.coll.F[a] = static_cast<T>(s_.body_force[static_cast<std::size_t>(a)]);
    for_each_cell(ex, g_, box, k);
  }

  LbmSetup s_;
  Exec ex_;
  Lanes lanes_;
  GridView g_;
  CellBox owned_;
  Index stride_ = 0;
  Buffer<T> f0_, f1_;
  Buffer<std::uint8_t> flags_;
  Buffer<double> rho_d_, u_d_;
  Scratch scratch_;
  bool has_bnd_ = false;
  bool force_ = false;
  double omega_p_ = 1, omega_m_ = 1;
  long t_ = 0;
};

}  // namespace lbdem::lbm
