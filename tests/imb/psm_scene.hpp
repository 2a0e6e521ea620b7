#pragma once
// A small PSM scene for the imb tests: an LBM solver on a periodic box, a few
// spheres (or disks) held on the solver's backend, and the PsmCoupling that
// steps them. Moving particles are updated on the host and copied (a few
// hundred bytes per step: simple, and exact on both backends).
#include <algorithm>
#include <cmath>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/buffer.hpp"
#include "imb/psm_coupling.hpp"
#include "lbm/solver.hpp"

namespace lbdem::test {

// One particle, lattice units: centre, radius, velocity, angular velocity.
struct PsmSphere {
  double x = 0, y = 0, z = 0, r = 1;
  double vx = 0, vy = 0, vz = 0;
  double wx = 0, wy = 0, wz = 0;
};

class PsmScene {
 public:
  // u0: initial velocity of every cell (rho = 1).
  PsmScene(const lbm::LbmSetup& setup, Backend b, int K, const std::vector<PsmSphere>& ps, const imb::PsmOptions& opt,
           std::array<double, 3> u0 = {0, 0, 0})
      : opt_(opt), n_(static_cast<Index>(ps.size())), pd_(b, 10 * std::max<Index>(n_, 1)),
        f6_(b, 6 * std::max<Index>(n_, 1)) {
    solver_ = lbm::make_lbm_solver(setup, b);
    // Storage cells; on a piece with ghost layers those are flagged as ghosts.
    cells_ = static_cast<std::size_t>(setup.domain.storage_cells());
    std::vector<double> u(3 * cells_);
    for (std::size_t c = 0; c < cells_; ++c)
      for (int a = 0; a < 3; ++a) u[3 * c + static_cast<std::size_t>(a)] = u0[static_cast<std::size_t>(a)];
    std::vector<std::uint8_t> flags(cells_, 0);
    const GridView g = setup.domain.view();
    const CellBox o = setup.domain.owned();
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x)
          if (x < o.lo[0] || x >= o.lo[0] + o.ext[0] || y < o.lo[1] || y >= o.lo[1] + o.ext[1] || z < o.lo[2] ||
              z >= o.lo[2] + o.ext[2])
            flags[static_cast<std::size_t>(g.index(x, y, z))] = lbm::kGhostFlag;
    solver_->initialize(flags, std::vector<double>(cells_, 1.0), u);
    double* p = pd_.data();
    view_.x = p; view_.y = p + n_; view_.z = p + 2 * n_; view_.r = p + 3 * n_;
    view_.vx = p + 4 * n_; view_.vy = p + 5 * n_; view_.vz = p + 6 * n_;
    view_.wx = p + 7 * n_; view_.wy = p + 8 * n_; view_.wz = p + 9 * n_;
    if (setup.lattice == lbm::LatticeKind::D2Q9) view_.z = nullptr;
    view_.n = n_;
    for (const auto& s : ps) opt_.map.max_radius = std::max(opt_.map.max_radius, s.r);
    coupling_ = std::make_unique<imb::PsmCoupling>(*solver_, K);
    set_particles(ps);
  }

  // Copies new particle states to the backend (does not remap).
  void set_particles(const std::vector<PsmSphere>& ps) {
    std::vector<double> h(static_cast<std::size_t>(10 * n_));
    for (Index i = 0; i < n_; ++i) {
      const PsmSphere& s = ps[static_cast<std::size_t>(i)];
      const double v[10] = {s.x, s.y, s.z, s.r, s.vx, s.vy, s.vz, s.wx, s.wy, s.wz};
      for (int k = 0; k < 10; ++k) h[static_cast<std::size_t>(k * n_ + i)] = v[k];
    }
    pd_.copy_from_host(h);
  }
  void map(bool check_overflow = true) { coupling_->map(view_, opt_, check_overflow); }
  void step() { coupling_->step(view_, opt_, f6_.data()); }
  // Force (0..2) and torque (3..5) of each particle from the last step, host copy.
  std::vector<double> forces() const { return f6_.to_vector(); }

  // Superficial velocity relative to a velocity V: sum over cells of
  // (1 - eps) (u - V) / cells, eps the total solid fraction (clamped to 1) of
  // the current mapping. The velocity of the array theory (Sangani & Acrivos
  // 1982: mean over the whole period, solid included, the solid moving at V).
  std::array<double, 3> superficial(std::array<double, 3> V = {0, 0, 0}) {
    std::vector<double> rho, u;
    solver_->macroscopic(rho, u);
    const auto eps = coupling_->solid_fraction_host(view_, opt_);
    std::array<double, 3> s{0, 0, 0};
    for (std::size_t c = 0; c < cells_; ++c) {
      const double w = 1.0 - std::min(1.0, eps[c]);
      for (std::size_t a = 0; a < 3; ++a) s[a] += w * (u[3 * c + a] - V[a]);
    }
    for (double& v : s) v /= static_cast<double>(cells_);
    return s;
  }

  lbm::LbmSolver& solver() { return *solver_; }
  imb::PsmCoupling& coupling() { return *coupling_; }
  const imb::PsmParticles& particles() const { return view_; }
  double* force6() { return f6_.data(); }
  imb::PsmOptions& options() { return opt_; }
  std::size_t cells() const { return cells_; }

 private:
  imb::PsmOptions opt_;
  Index n_;
  Buffer<double> pd_, f6_;
  imb::PsmParticles view_;
  std::unique_ptr<lbm::LbmSolver> solver_;
  std::unique_ptr<imb::PsmCoupling> coupling_;
  std::size_t cells_ = 0;
};

// Comparison helpers of the PSM tests.
inline double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}
inline double max_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

// Largest difference of particle forces (0..2) and torques (3..5) relative to
// the largest force resp. torque in the scene; `perm` maps b's particles to a's.
inline std::array<double, 2> force_torque_diff(const std::vector<double>& a, const std::vector<double>& b,
                                        const std::vector<int>& perm_b_to_a) {
  double fa = 0, ta = 0, df = 0, dt = 0;
  for (std::size_t i = 0; i < perm_b_to_a.size(); ++i) {
    const std::size_t j = static_cast<std::size_t>(perm_b_to_a[i]);
    for (std::size_t k = 0; k < 3; ++k) {
      fa = std::max(fa, std::abs(a[6 * j + k]));
      ta = std::max(ta, std::abs(a[6 * j + 3 + k]));
      df = std::max(df, std::abs(a[6 * j + k] - b[6 * i + k]));
      dt = std::max(dt, std::abs(a[6 * j + 3 + k] - b[6 * i + 3 + k]));
    }
  }
  return {df / fa, dt / ta};
}

// D3Q19 (or D2Q9 with nz = 1) periodic box, fp64, TRT, AA streaming.
inline lbm::LbmSetup psm_box(long nx, long ny, long nz, double tau, double magic,
                             std::array<double, 3> body_force = {0, 0, 0}) {
  lbm::LbmSetup s;
  s.lattice = nz == 1 ? lbm::LatticeKind::D2Q9 : lbm::LatticeKind::D3Q19;
  s.precision = lbm::Precision::FP64;
  s.collision = lbm::CollisionKind::TRT;
  s.streaming = lbm::StreamKind::AA;
  s.tau = tau;
  s.magic = magic;
  s.domain.global = s.domain.local = {nx, ny, nz};
  s.body_force = body_force;
  return s;
}

}  // namespace lbdem::test
