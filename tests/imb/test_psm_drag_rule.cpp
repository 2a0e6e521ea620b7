// The PSM wall rule (imb::psm_wall_weight_t, the noble_torczynski_wall
// weighting) and the expected drag error told to the user
// (imb/drag_error.hpp): bench/imb/NOTES.md, "Where the PSM wall sits".
//
// Fixed sphere in a simple cubic array, chi = 0.5, Re_p 0.2, exact fractions,
// fp64, NEBB, Lambda auto, sphere centre on a cell centre, against Sangani &
// Acrivos (1982); the bar is half the first paper's Table 1 error.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "../../bench/imb/psm_plane_wall.hpp"
#include "imb/fixed_sphere.hpp"
#include "imb/drag_error.hpp"
#include "imb/fraction_table.hpp"
#include "psm_scene.hpp"

using namespace lbdem;

namespace {

imb::FixedSphereSpec rule_spec(double d, double tau) {
  imb::FixedSphereSpec s;
  s.dim = 3;
  s.diameter = d;
  s.chi = 0.5;
  s.re_p = 0.2;
  s.tau = tau;
  s.collision = lbm::CollisionKind::TRT;
  s.magic = imb::psm_magic_auto(d, tau);
  s.precision = lbm::Precision::FP64;
  s.method = imb::FractionMethod::Exact;
  s.variant = imb::PsmVariant::NEBB;
  s.weight = imb::PsmWeight::NobleTorczynskiWall;
  s.offset = 0.5;
  s.tolerance = 1e-5;
  return s;
}

double measured_error(double d, double tau) {
  const auto r = imb::run_fixed_sphere(rule_spec(d, tau), Backend::Host);
  EXPECT_TRUE(r.converged);
  std::printf("d/l %g tau %g: K = %.5f, error %+.3f%%, %ld steps\n", d, tau, r.K, 100 * r.rel_error, r.steps);
  return r.rel_error;
}

}  // namespace

// The rule's t: tau - 1/2 in the limit tau -> 1/2, larger above; the classic
// NT weighting keeps t = tau - 1/2 exactly (its kernels compute the same bits).
TEST(PsmWallRule, WeightParameter) {
  EXPECT_EQ(imb::psm_weight_t(0.8, imb::PsmWeight::NobleTorczynski), 0.8 - 0.5);
  EXPECT_NEAR(imb::psm_wall_weight_t(0.5001) / 1e-4, 1.0, 4e-4);
  double prev = 0;
  for (double tau : {0.505, 0.52, 0.6, 0.8, 1.0, 1.5, 3.0}) {
    const double t = imb::psm_wall_weight_t(tau);
    EXPECT_GT(t, tau - 0.5) << tau;
    EXPECT_GT(t, prev) << tau;
    EXPECT_TRUE(std::isfinite(t)) << tau;
    prev = t;
    for (double eps : {0.0, 0.3, 0.9, 1.0}) {
      const double B = imb::psm_weight(eps, t, imb::PsmWeight::NobleTorczynskiWall);
      EXPECT_GE(B, 0.0);
      EXPECT_LE(B, 1.0);
    }
  }
}

// Plane PSM walls: with the classic weighting the wall moves into the solid
// as tau grows (the drag falls); the rule's larger t moves it back toward the
// fluid at every wall fraction.
TEST(PsmWallRule, PlaneWallShiftsBack) {
  for (double eps : {0.25, 0.5, 0.75}) {
    bench::PlaneWallSpec s;
    s.couette = true;
    s.tau = 0.8;
    s.wall_eps = eps;
    s.gap = 10;
    s.tol = 1e-9;
    const double nt = bench::run_plane_wall(s).delta;
    s.tau = 0.52;
    const double nt_low = bench::run_plane_wall(s).delta;
    s.tau = 0.8;
    s.weight = [](double e, double) {
      return imb::psm_weight(e, imb::psm_wall_weight_t(0.8), imb::PsmWeight::NobleTorczynskiWall);
    };
    const double rule = bench::run_plane_wall(s).delta;
    EXPECT_GT(nt, nt_low) << eps;  // NT: deeper into the solid at the larger tau
    EXPECT_LT(rule, nt) << eps;    // the rule: back toward the fluid
  }
}

// Lambda auto and the bar.
TEST(PsmDragError, AutoLambdaAndBar) {
  EXPECT_EQ(imb::psm_magic_auto(10, 0.52), 1e-4);
  EXPECT_EQ(imb::psm_magic_auto(16, 0.52), 3e-2);
  EXPECT_NEAR(imb::psm_drag_bar(10), 0.01434, 1e-5);
  EXPECT_NEAR(imb::psm_drag_bar(50), 0.0016675, 1e-6);
  EXPECT_NEAR(imb::psm_drag_bar(2), imb::psm_drag_bar(4), 1e-15);  // clamped to the map
}

// Settings outside the map get no estimate, with the reason.
TEST(PsmDragError, OutsideTheMap) {
  imb::DragErrorQuery q;
  q.diameter = 10;
  q.tau = 0.6;
  q.magic = imb::psm_magic_auto(10, q.tau);
  EXPECT_TRUE(imb::expected_drag_error(q).known);
  auto o = q;
  o.weight = imb::PsmWeight::NobleTorczynski;
  EXPECT_FALSE(imb::expected_drag_error(o).known);
  o = q;
  o.magic = 0.5 * q.magic;
  EXPECT_FALSE(imb::expected_drag_error(o).known);
  o = q;
  o.method = imb::FractionMethod::Linear;
  EXPECT_FALSE(imb::expected_drag_error(o).known);
  o = q;
  o.even_relaxation = 0.02;  // moves the drag (bench/imb/NOTES.md, "Even relaxation"); not mapped
  EXPECT_FALSE(imb::expected_drag_error(o).known);
  EXPECT_NE(imb::expected_drag_error(o).reason.find("even_relaxation"), std::string::npos);
  o = q;
  o.dim = 2;  // disks: the 2D map, with the same setting checks
  EXPECT_TRUE(imb::expected_drag_error(o).known);
  o.weight = imb::PsmWeight::NobleTorczynski;
  EXPECT_FALSE(imb::expected_drag_error(o).known);
  o = q;
  o.fp32 = true;
  o.diameter = 30;
  o.magic = imb::psm_magic_auto(30, o.tau);
  const auto e = imb::expected_drag_error(o);
  EXPECT_FALSE(e.known);
  EXPECT_NE(e.reason.find("fp32"), std::string::npos);
  o = q;
  o.tau = 1.6;  // the map ends at tau 1.5
  o.magic = imb::psm_magic_auto(10, o.tau);
  EXPECT_FALSE(imb::expected_drag_error(o).known);
  // The shipped suspensions' setting (d/l 10, tau 1.2386, Lambda auto, table
  // fractions, fp32) is inside: between the map's tau 1 and 1.25 nodes.
  o = q;
  o.tau = 1.2386;
  o.magic = imb::psm_magic_auto(10, o.tau);
  o.method = imb::FractionMethod::Table;
  o.fp32 = true;
  const auto s = imb::expected_drag_error(o);
  EXPECT_TRUE(s.known) << s.reason;
  EXPECT_LE(std::abs(s.error), 0.05);
}

// The 2D map (fixed disks in square arrays, chi 0.3; bench/results/
// drag_map_2d_host.md): its nodes come back exactly (the worse of the two
// disk positions, the other named), a point between nodes lies between
// them, outside the map and off the default setting there is no estimate,
// and no bar is claimed (the first paper's Table 1 is of spheres).
TEST(PsmDragError, DiskMap2D) {
  using namespace imb::detail;
  imb::DragErrorQuery q;
  q.dim = 2;
  for (int i = 0; i < kMap2dRows; ++i)
    for (int j = 0; j < kMap2dTaus; ++j) {
      q.diameter = kDragMap2dD[i];
      q.tau = kDragMap2dTau[j];
      q.magic = imb::psm_magic_auto(q.diameter, q.tau);
      const auto e = imb::expected_drag_error(q);
      ASSERT_TRUE(e.known) << e.reason;
      EXPECT_FALSE(e.has_bar);
      const double c = kDragMap2dCorner[i][j], m = kDragMap2dCentre[i][j];
      EXPECT_EQ(e.error, 1e-2 * (std::abs(c) >= std::abs(m) ? c : m)) << "d/l " << q.diameter << " tau " << q.tau;
      EXPECT_NE(e.reason.find("fixed disk in a square array, chi 0.3"), std::string::npos) << e.reason;
      EXPECT_NE(e.reason.find("no published bar in 2D"), std::string::npos) << e.reason;
    }
  // Between nodes: each position's value lies between its table's four
  // surrounding nodes, and the estimate is the worse of the two.
  for (const auto& [d, tau] : {std::pair{9.0, 0.7}, std::pair{12.0, 0.86928}, std::pair{18.0, 1.4}}) {
    int i = 0, j = 0;
    while (d > kDragMap2dD[i + 1]) ++i;
    while (tau > kDragMap2dTau[j + 1]) ++j;
    double v[2];
    int k = 0;
    for (const auto* t : {&kDragMap2dCorner, &kDragMap2dCentre}) {
      const double n[4] = {(*t)[i][j], (*t)[i][j + 1], (*t)[i + 1][j], (*t)[i + 1][j + 1]};
      v[k] = map_bilinear(kDragMap2dD, kDragMap2dTau, *t, d, tau);
      EXPECT_GE(v[k], *std::min_element(n, n + 4) - 1e-12) << "d/l " << d << " tau " << tau;
      EXPECT_LE(v[k], *std::max_element(n, n + 4) + 1e-12) << "d/l " << d << " tau " << tau;
      ++k;
    }
    q.diameter = d;
    q.tau = tau;
    q.magic = imb::psm_magic_auto(d, tau);
    const auto e = imb::expected_drag_error(q);
    ASSERT_TRUE(e.known) << e.reason;
    EXPECT_DOUBLE_EQ(e.error, 1e-2 * (std::abs(v[0]) >= std::abs(v[1]) ? v[0] : v[1]));
  }
  // Outside: below and above the map's d/l and tau.
  for (const auto& [d, tau] :
       {std::pair{6.0, 0.8}, std::pair{30.0, 0.8}, std::pair{10.0, 0.51}, std::pair{10.0, 1.6}}) {
    q.diameter = d;
    q.tau = tau;
    q.magic = imb::psm_magic_auto(d, tau);
    const auto e = imb::expected_drag_error(q);
    EXPECT_FALSE(e.known) << "d/l " << d << " tau " << tau;
    EXPECT_NE(e.reason.find("outside the 2D map (d/l 8-20, tau 0.52-1.5)"), std::string::npos) << e.reason;
  }
  // Off the default setting: a Lambda of the file's own.
  q.diameter = 10;
  q.tau = 0.8;
  q.magic = 1e-4;
  EXPECT_FALSE(imb::expected_drag_error(q).known);
}

// The 2D estimate at the shipped 2D suspensions' point (d/l 10, tau 0.86928,
// between the map's tau 0.8 and 1 nodes) against a fixed-disk run there, both
// disk positions. Measured (chi 0.3, exact fp64): corner +1.530 %, centre
// -0.026 %; the map gives +1.39 / -0.03. Within 0.3 points (the map's
// linear-in-tau step from 0.8 to 1 moves the corner value by 0.18).
TEST(PsmDragError, DiskMap2DMatchesTheSuspensionPoint) {
  imb::DragErrorQuery q;
  q.dim = 2;
  q.diameter = 10;
  q.tau = 0.86928;
  q.magic = imb::psm_magic_auto(q.diameter, q.tau);
  using namespace imb::detail;
  const double corner = map_bilinear(kDragMap2dD, kDragMap2dTau, kDragMap2dCorner, q.diameter, q.tau);
  const double centre = map_bilinear(kDragMap2dD, kDragMap2dTau, kDragMap2dCentre, q.diameter, q.tau);
  for (const double off : {0.0, 0.5}) {
    auto s = rule_spec(q.diameter, q.tau);
    s.dim = 2;
    s.chi = 0.3;
    s.offset = off;
    const auto r = imb::run_fixed_sphere(s, Backend::Host);
    EXPECT_TRUE(r.converged);
    std::printf("disk d/l 10, tau 0.86928, offset %g: error %+.3f%%, map %+.3f%%\n", off, 100 * r.rel_error,
                off == 0 ? corner : centre);
    EXPECT_NEAR(100 * r.rel_error, off == 0 ? corner : centre, 0.3) << "offset " << off;
  }
  const auto e = imb::expected_drag_error(q);
  ASSERT_TRUE(e.known) << e.reason;
  EXPECT_DOUBLE_EQ(e.error, 1e-2 * (std::abs(corner) >= std::abs(centre) ? corner : centre));
}

// The rule at a grid of small-d/l points (host): drag within the bar.
// Measured: d/l 6 -2.17 / -1.84 % at tau 0.8 / 1.0 (bar 3.48), d/l 8 -0.68 /
// -0.64 % (bar 2.18). The one point of the host map where the rule misses
// (NOTES, "One rule for every tau"): d/l 4 at tau 1 (-8.29 %, bar 8.00).
class PsmDragRuleGrid : public ::testing::TestWithParam<std::pair<double, double>> {};
TEST_P(PsmDragRuleGrid, WithinBar) {
  const auto [d, tau] = GetParam();
  const double e = measured_error(d, tau);
  EXPECT_LE(std::abs(e), imb::psm_drag_bar(d)) << "d/l " << d << " tau " << tau;
}
INSTANTIATE_TEST_SUITE_P(Host, PsmDragRuleGrid,
                         ::testing::Values(std::make_pair(6.0, 0.8), std::make_pair(6.0, 1.0), std::make_pair(8.0, 0.8),
                                           std::make_pair(8.0, 1.0)));

// d/l 4: the rule against the classic weighting at the same Lambda (measured
// at tau 0.8, Lambda auto 0.011: -6.85 % against -21.34 %).
TEST(PsmWallRule, Dl4BetterThanClassic) {
  auto s = rule_spec(4, 0.8);
  const double rule = imb::run_fixed_sphere(s, Backend::Host).rel_error;
  s.weight = imb::PsmWeight::NobleTorczynski;
  const double nt = imb::run_fixed_sphere(s, Backend::Host).rel_error;
  std::printf("d/l 4, tau 0.8: rule %+.3f%%, classic NT %+.3f%%\n", 100 * rule, 100 * nt);
  EXPECT_LT(std::abs(rule), std::abs(nt));
}

// The expected-error report against the measured error of three cases that
// are not map points (d/l and tau between the map's nodes). Measured: d/l 6,
// tau 0.75: -2.08 % (report -2.21); d/l 7, tau 0.85: -1.64 (-1.32); d/l 9,
// tau 0.65: +0.10 (-0.03).
TEST(PsmDragError, ReportMatchesUnmappedCases) {
  const std::pair<double, double> cases_[3] = {{6.0, 0.75}, {7.0, 0.85}, {9.0, 0.65}};
  for (const auto& [d, tau] : cases_) {
    imb::DragErrorQuery q;
    q.diameter = d;
    q.tau = tau;
    q.magic = imb::psm_magic_auto(d, tau);
    const auto est = imb::expected_drag_error(q);
    ASSERT_TRUE(est.known) << est.reason;
    const double meas = measured_error(d, tau);
    std::printf("  expected %+.3f%%, measured %+.3f%%\n", 100 * est.error, 100 * meas);
    // Interpolation in 1/d and tau between nodes two cells apart: within a
    // quarter of the bar (the report's use: is the error near or above the bar).
    EXPECT_NEAR(est.error, meas, 0.25 * est.bar) << "d/l " << d << " tau " << tau;
  }
}

// Torque on a sphere spinning in a periodic box with the rule (d/l 8, tau 0.8,
// Lambda auto = 0.15, exact fractions), against the Stokes couple corrected for
// the periodic images, T = -8 pi mu a^3 Omega / (1 - phi) (derivation in
// test_psm_rotation.cpp). Within 3 % (measured T / T_ref = 1.0089).
TEST(PsmWallRule, RotatingSphereCouple) {
  const long L = 20;
  const double a = 4, tau = 0.8, Omega = 2.5e-4, mu = (tau - 0.5) / 3.0;
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Exact;
  opt.weight = imb::PsmWeight::NobleTorczynskiWall;
  test::PsmSphere s;
  s.x = 0.5 * L + 0.23;
  s.y = 0.5 * L + 0.115;
  s.z = 0.5 * L - 0.069;
  s.r = a;
  s.wz = Omega;
  test::PsmScene scene(test::psm_box(L, L, L, tau, imb::psm_magic_auto(2 * a, tau)), Backend::Host, 2, {s}, opt);
  scene.map();
  for (int i = 0; i < 1500; ++i) scene.step();
  const double phi = 4.0 / 3.0 * M_PI * a * a * a / double(L * L * L);
  const double T_ref = -8 * M_PI * mu * a * a * a * Omega / (1 - phi);
  const double T = scene.forces()[5];
  std::printf("rule, tau 0.8, d/l 8: T/T_ref = %.5f\n", T / T_ref);
  EXPECT_NEAR(T / T_ref, 1.0, 0.03);
}

// Galilean consistency with the rule: a sphere held in a fluid driven by a
// body force, and the same sphere carried at V through fluid that starts at V
// (the first run seen from a frame moving at -V), give the same superficial
// relative velocity (the measure of test_psm_galilean.cpp; d/l 8 in 16^3,
// tau 0.8, Lambda auto = 0.15, table fractions, |V| = 0.02). Measured (host,
// fp64): U_moving / U_fixed - 1 = +2.6e-3 (the classic weighting at tau 0.6,
// Lambda 3/16 gives +5.6e-4, test_psm_galilean.cpp); asserted within the
// 0.5 % asked for (a solid velocity left out of the solid operator would be
// off by O(10), see test_psm_galilean.cpp).
TEST(PsmWallRule, MovingSphereMatchesFixed) {
  static const imb::FractionTable table = imb::build_fraction_table(3);
  const long L = 16;
  const double a = 4, tau = 0.8, nu = (tau - 0.5) / 3.0;
  const double U0 = 0.2 * nu / (2 * a);
  const double g = 6 * M_PI * nu * a * 2.842 * U0 / double(L * L * L);
  const auto setup = test::psm_box(L, L, L, tau, imb::psm_magic_auto(2 * a, tau), {g, 0, 0});
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Table;
  opt.map.table = &table;
  opt.weight = imb::PsmWeight::NobleTorczynskiWall;
  const std::array<double, 3> V{-0.02, 0, 0};
  const double x0 = 0.5 * L + 0.3;
  test::PsmSphere fixed{x0, x0, x0, a};
  test::PsmScene A(setup, Backend::Host, 4, {fixed}, opt);
  test::PsmScene B(setup, Backend::Host, 4, {fixed}, opt, V);
  A.map();
  const long transient = 1500, window = 100;  // window: two cell crossings at |V| = 0.02
  double ua = 0, ub = 0;
  for (long st = 0; st < transient + window; ++st) {
    test::PsmSphere m = fixed;
    m.x += V[0] * double(st);
    m.vx = V[0];
    B.set_particles({m});
    B.map();
    if (st >= transient) {
      ua += A.superficial()[0] / double(window);
      ub += B.superficial(V)[0] / double(window);
    }
    A.step();
    B.step();
  }
  std::printf("rule, tau 0.8, d/l 8: U_moving / U_fixed - 1 = %+.2e\n", ub / ua - 1);
  EXPECT_GT(ua, 0);
  EXPECT_NEAR(ub / ua, 1.0, 5e-3);
}
