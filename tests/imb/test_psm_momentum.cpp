// Total momentum of a weight-balanced, fully periodic suspension (issue 16).
//
// Per coupled step the system (fluid + particles) receives
//   - from gravity and buoyancy on the particles: W = sum_p (m_p - rho_f V_p) g,
//   - from the fluid body force F: (1 - B) F in each cell through the fluid's
//     forcing, plus B F to the particles that cover the cell (their share of
//     the mean pressure gradient, PsmOptions::body_force_on_solid), i.e. F V;
//   - nothing from the solid term or the contacts (action = reaction).
// With F = -W / V (imb::balancing_body_force) the total stays at its initial
// value to round-off, whatever the solid fractions (exact, table, linear), the
// pipeline (mapped, fused) or the lattice. The bar (issue 16): |P(n) - P(0)|
// <= 1e-12 of the weight impulse |W| n after 10^4 steps.
//
// The momentum is read at step boundaries as sum_q c_q f_q (the incoming
// populations, no half-force shift) plus sum_p m_p v_p (the DEM's synchronised
// velocities), corrected for one lag of the DEM: the first half kick of a
// coupled step uses the force of the step before (its forces are kept across
// advance() calls), so after step n the particles have received
// sum_k E_k - (dt/2)(E_n - E_1), E_k the hydrodynamic force + buoyancy of step
// k summed over particles, dt = 1/substeps (a bounded offset, not a drift:
// see tests/imb/test_psm_hard_cases.cpp). The test adds (dt/2)(E_n - E_1) back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "../common/backends.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/fraction_table.hpp"
#include "lbm/solver.hpp"

using namespace lbdem;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr long kSteps = 10000;

const imb::FractionTable& table(int dim) {
  static const imb::FractionTable t3 = imb::build_fraction_table(3);
  static const imb::FractionTable t2 = imb::build_fraction_table(2);
  return dim == 3 ? t3 : t2;
}

struct Case {
  int dim;
  imb::FractionMethod method;
  imb::PsmPipeline pipeline;
  Backend backend;
};

std::string case_name(const ::testing::TestParamInfo<Case>& i) {
  return std::string(i.param.dim == 3 ? "D3Q19" : "D2Q9") + "_" + imb::to_string(i.param.method) + "_" +
         imb::to_string(i.param.pipeline) + "_" + to_string(i.param.backend);
}

std::vector<Case> all_cases() {
  std::vector<Case> v;
  for (Backend b : test::backends())
    for (int dim : {3, 2}) {
      v.push_back({dim, imb::FractionMethod::Exact, imb::PsmPipeline::Mapped, b});
      v.push_back({dim, imb::FractionMethod::Table, imb::PsmPipeline::Mapped, b});
      v.push_back({dim, imb::FractionMethod::Linear, imb::PsmPipeline::Mapped, b});
      v.push_back({dim, imb::FractionMethod::Table, imb::PsmPipeline::Fused, b});
      v.push_back({dim, imb::FractionMethod::Linear, imb::PsmPipeline::Fused, b});
    }
  return v;
}

struct Totals {
  double fluid = 0, particles = 0, hydro = 0;  // y components
};

// Four spheres d/l = 5 (disks d/l = 6) of density ratio 10 in a 12^3 (24^2)
// periodic box with random initial velocities, gravity along -y balanced by
// the fluid body force; TRT, tau 0.6, 5 DEM sub-steps, soft contacts. Runs
// `steps` coupled steps and checks the total momentum against the bar.
void run_case(const Case& c, long steps) {
  const bool d3 = c.dim == 3;
  const long L = d3 ? 12 : 24;
  const double r = d3 ? 2.5 : 3.0, rho_s = 10.0, tau = 0.6;
  const int substeps = 5;
  const std::array<double, 3> g{0, -2e-5, 0};
  dem::HostParticles hp;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> X(0.0, double(L)), U(-2e-3, 2e-3);
  while (hp.size() < 4) {  // non-overlapping, 1 cell apart
    const Vec3d x{X(rng), X(rng), d3 ? X(rng) : 0.5};
    bool free = true;
    for (const Vec3d& y : hp.x) {
      Vec3d d = x - y;
      for (int a = 0; a < c.dim; ++a) d[a] -= double(L) * std::round(d[a] / double(L));
      free = free && dot(d, d) > (2 * r + 1) * (2 * r + 1);
    }
    if (free) hp.add(x, r, rho_s, {U(rng), U(rng), d3 ? U(rng) : 0.0});
  }
  lbm::LbmSetup s;
  s.lattice = d3 ? lbm::LatticeKind::D3Q19 : lbm::LatticeKind::D2Q9;
  s.precision = lbm::Precision::FP64;
  s.collision = lbm::CollisionKind::TRT;
  s.tau = tau;
  s.magic = 1e-3;
  s.domain.global = s.domain.local = {L, L, d3 ? L : 1};
  const double volume = d3 ? double(L * L * L) : double(L * L);
  s.body_force = imb::balancing_body_force(hp, c.dim, g, 1.0, volume);
  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {double(L), double(L), d3 ? double(L) : 1.0};
  dp.periodic = {true, true, d3};
  dp.gravity = {g[0], g[1], g[2]};
  dp.external_forcing = true;
  dp.dt = 1.0 / substeps;
  dp.material.stiffness = 20;
  dp.material.restitution = 0.9;
  imb::CoupledParams cp;
  cp.gravity = g;
  cp.dem_substeps = substeps;
  cp.psm.map.method = c.method;
  cp.psm.map.table = &table(c.dim);
  cp.psm.map.max_radius = r;
  cp.psm.pipeline = c.pipeline;
  imb::check_coupled_setup(s, dp, hp, cp);  // accepts the balance

  auto fluid = lbm::make_lbm_solver(s, c.backend);
  const auto N = static_cast<std::size_t>(s.domain.cells());
  fluid->initialize(std::vector<std::uint8_t>(N, 0), std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  dem::DemSystem dem(Exec(c.backend), dp, hp);
  imb::CoupledSolver cs(*fluid, dem, cp);
  ASSERT_EQ(cs.coupling().pipeline(), c.pipeline);

  double W = 0;  // net weight per step (y)
  for (std::size_t i = 0; i < hp.r.size(); ++i)
    W += (hp.mass[i] - (d3 ? 4.0 / 3.0 * kPi * r * r * r : kPi * r * r)) * g[1];
  auto totals = [&] {
    Totals t;
    t.fluid = fluid->diagnostics().momentum[1];
    const auto h = dem.download();
    for (std::size_t i = 0; i < h.v.size(); ++i) t.particles += h.mass[i] * h.v[i].y;
    const auto f = cs.hydro_force_host();
    for (std::size_t i = 0; i < f.size() / 3; ++i) t.hydro += f[3 * i + 1];
    return t;
  };
  const Totals t0 = totals();
  cs.step();
  const double E1 = totals().hydro;
  double P0 = t0.fluid + t0.particles, worst = 0, max_fluid = 0;
  for (long n = 1; n < steps;) {
    const long k = std::min<long>(n < 100 ? 9 : 1000, steps - n);
    cs.advance(k);
    n += k;
    const Totals t = totals();
    const double P = t.fluid + t.particles + 0.5 / substeps * (t.hydro - E1);
    worst = std::max(worst, std::abs(P - P0) / (std::abs(W) * double(n)));
    max_fluid = std::max(max_fluid, std::abs(t.fluid));
  }
  const double impulse = std::abs(W) * double(steps);
  std::printf("%s: weight impulse %.4e over %ld steps; |fluid momentum| up to %.4e; |P - P(0)| / (|W| n) <= %.2e\n",
              case_name({c, 0}).c_str(), impulse, steps, max_fluid, worst);
  // The exchange is not trivial: the fluid carries a momentum of the order of
  // the weight impulse (the particles' equal and opposite one).
  EXPECT_GT(max_fluid, 1e-3 * impulse);
  EXPECT_LE(worst, 1e-12);
}

class PsmMomentum : public ::testing::TestWithParam<Case> {};

// 10^4 steps for every fraction method and pipeline, D3Q19 and D2Q9 (label long).
TEST_P(PsmMomentum, BalancedSuspensionKeepsTotalMomentum) { run_case(GetParam(), kSteps); }

INSTANTIATE_TEST_SUITE_P(Imb, PsmMomentum, ::testing::ValuesIn(all_cases()), case_name);

// The quick suite's share: 500 steps of two of the cases above on the host.
TEST(PsmMomentumQuick, TableFusedD3Q19AndExactMappedD2Q9) {
  run_case({3, imb::FractionMethod::Table, imb::PsmPipeline::Fused, Backend::Host}, 500);
  run_case({2, imb::FractionMethod::Exact, imb::PsmPipeline::Mapped, Backend::Host}, 500);
}

// The balancing force is -W / V with W from the DEM's masses (in 2D too: a
// sphere's mass, the one its gravity acts on) and the buoyancy's volumes.
TEST(PsmMomentumBalance, BodyForceIsNetWeightOverVolume) {
  dem::HostParticles hp;
  hp.add({4, 4, 4}, 2.0, 3.0);
  hp.add({10, 10, 10}, 1.5, 5.0);
  const std::array<double, 3> g{1e-6, -2e-6, 0};
  const double V = 20.0 * 20 * 20;
  const auto F3 = imb::balancing_body_force(hp, 3, g, 1.0, V);
  double net3 = 0, net2 = 0;
  for (std::size_t i = 0; i < hp.r.size(); ++i) {
    const double r = hp.r[i];
    net3 += hp.mass[i] - 4.0 / 3.0 * kPi * r * r * r;
    net2 += hp.mass[i] - kPi * r * r;
  }
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(F3[a], -net3 * g[a] / V, 1e-15 * std::abs(net3 * 2e-6 / V));
  const auto F2 = imb::balancing_body_force(hp, 2, g, 1.0, 400.0);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(F2[a], -net2 * g[a] / 400.0, 1e-15 * std::abs(net2 * 2e-6 / 400.0));
}

}  // namespace
