// MFIX-DEM verification cases DEM01 (falling particle), DEM02 (bounce
// heights) and DEM03 (two stacked particles between walls), after Garg et al.
// (2012); reference values in /work/shared/REFERENCES.md.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>

#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;
using namespace lbdem::dem::test;

namespace {

// Analytic three-stage solution of a particle dropped on a linear
// spring-dashpot wall (REFERENCES.md, DEM01): free fall, damped contact
// oscillation about the static overlap, ballistic rebound.
struct Dem01Analytic {
  double r, h0, k, e, m;
  double w0, b, c0, tc, vi, A, B, tr = 0, vr = 0;
  Dem01Analytic(double r_, double h0_, double k_, double e_, double m_) : r(r_), h0(h0_), k(k_), e(e_), m(m_) {
    w0 = std::sqrt(k / m);
    b = damping_ratio_from_restitution(e);
    c0 = w0 * std::sqrt(1 - b * b);
    tc = std::sqrt(2 * (h0 - r) / kG);
    vi = std::sqrt(2 * kG * (h0 - r));
    A = kG / (w0 * w0);
    B = (b * kG / w0 - vi) / c0;
    // Contact end: first return of y to r (bisection on the half period).
    double lo = 0.5 * M_PI / c0, hi = 1.5 * M_PI / c0;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (contact_y(mid) < r ? lo : hi) = mid;
    }
    tr = tc + 0.5 * (lo + hi);
    vr = contact_v(tr - tc);
  }
  double contact_y(double tau) const {
    return (A * std::cos(c0 * tau) + B * std::sin(c0 * tau)) * std::exp(-b * w0 * tau) + r - A;
  }
  double contact_v(double tau) const {
    const double ex = std::exp(-b * w0 * tau);
    return ex * (c0 * (-A * std::sin(c0 * tau) + B * std::cos(c0 * tau)) - b * w0 * (A * std::cos(c0 * tau) + B * std::sin(c0 * tau)));
  }
  double y(double t) const {
    if (t <= tc) return h0 - 0.5 * kG * t * t;
    if (t <= tr) return contact_y(t - tc);
    const double s = t - tr;
    return r + vr * s - 0.5 * kG * s * s;
  }
  double second_impact() const { return tr + 2 * vr / kG; }
};

DemParams dem01_params(double k, double e) {
  DemParams p;
  p.lo = {-0.5, -0.5, -0.5};
  p.hi = {0.5, 1.5, 0.5};
  p.walls = {Wall{{0, 0, 0}, {0, 1, 0}}};
  p.material = simple_material(k, e);
  p.gravity = {0, -kG, 0};
  return p;
}

}  // namespace

class DemVerification : public ::testing::TestWithParam<Backend> {};

// The analytic solution itself reproduces the contact-end values derived in
// REFERENCES.md (6 digits given there: tolerance 2e-6 s and 2e-6 m/s).
TEST(DemVerificationAnalytic, Dem01ContactEndMatchesReferences) {
  const double r = 0.1, m = 2600 * 4.0 / 3.0 * M_PI * r * r * r;
  const std::array<std::array<double, 4>, 4> ref{{{1e4, 0.9, 0.397435, 2.475443},
                                                  {1e4, 0.6, 0.401346, 1.491736},
                                                  {2.5e4, 1.0, 0.354233, 2.80095},
                                                  {1e5, 0.9, 0.319228, 2.507417}}};
  EXPECT_NEAR(m, 10.8909, 1e-4);
  for (const auto& c : ref) {
    Dem01Analytic a(r, 0.5, c[0], c[1], m);
    EXPECT_NEAR(a.tr, c[2], 2e-6) << "k=" << c[0] << " e=" << c[1];
    EXPECT_NEAR(a.vr, c[3], 2e-6) << "k=" << c[0] << " e=" << c[1];
  }
}

// DEM01: height against the three-stage analytic solution over the fall, the
// contact and the rebound flight (until just before the second impact), at
// the production step t_c/50. The error is normalised by the drop height
// h0 - r: with k = 1e4 the wall compresses the particle by about its radius,
// so y itself passes near 0 during the contact and a pointwise relative error
// would divide by ~0. Free fall is exact in velocity Verlet, the contact
// oscillation has an O((omega dt)^2) phase error and the onset/release
// quadrature (contact.hpp) is exact for linear overlap, so the 0.1 % target
// (the paper: 1.2 %) has a margin; the measured worst is printed: at t_c/50
// 1.1e-4 (k=1e4, e=0.9), 2.3e-4 (k=1e4, e=0.6), 7.9e-5 (e=1), 3.8e-5 (k=1e5).
TEST_P(DemVerification, Dem01FallingParticle) {
  const double r = 0.1;
  const std::array<std::array<double, 2>, 4> cases{{{1e4, 0.9}, {1e4, 0.6}, {2.5e4, 1.0}, {1e5, 0.9}}};
  for (const auto& c : cases) {
    for (ForcePath path : {ForcePath::Particle, ForcePath::Pair}) {
      HostParticles hp;
      hp.add({0, 0.5, 0}, r, 2600);
      DemParams p = dem01_params(c[0], c[1]);
      p.path = path;
      const double steps_per_tc = 50;
      p.dt = min_collision_time(p, hp) / steps_per_tc;
      Dem01Analytic a(r, 0.5, c[0], c[1], hp.mass[0]);
      DemSystem sys(Exec(GetParam()), p, hp);
      const double t_end = std::min(0.8, a.second_impact() - 0.02);
      double worst = 0, t = 0;
      while (t < t_end) {
        sys.advance(1);
        t = sys.time();
        const HostParticles o = sys.download();
        const double err = std::fabs(o.x[0].y - a.y(t)) / (0.5 - r);
        worst = std::max(worst, err);
      }
      EXPECT_LT(worst, 1e-3) << "k=" << c[0] << " e=" << c[1] << " path " << to_string(path);
      if (path == ForcePath::Particle)
        std::printf("[ DEM01 ] k=%g e=%g dt=t_c/%g: worst height error / drop height %.3e\n", c[0], c[1], steps_per_tc,
                    worst);
    }
  }
}

// DEM02: apex heights after 1, 2, 3 bounces (e = 0.9) against the hard-sphere
// values r + e^{2n} (h0 - r). A soft sphere lands below them because gravity
// acts during the contact: REFERENCES.md quotes ~1 % at k = 5e4 and ~0.6 % at
// 5e5 (per bounce; the deficit compounds, so bounce n may lie n times that
// below). The exact soft-sphere value of the first bounce follows from the
// analytic DEM01 solution (r + v_r^2 / 2g): we match it to 0.05 % (measured
// 3e-4 relative at t_c/50, second order in dt), and lie below the
// hard-sphere values by at most n x (1.2 %, 0.6 %, 0.2 %) for k = 5e4, 5e5,
// 5e6 (measured per bounce: 1.16 %, 0.37 %, 0.12 %).
TEST_P(DemVerification, Dem02BounceHeights) {
  const double r = 0.1, h0 = 0.5, e = 0.9;
  const std::array<std::array<double, 2>, 3> cases{{{5e4, 0.012}, {5e5, 0.006}, {5e6, 0.002}}};
  for (const auto& c : cases) {
    HostParticles hp;
    hp.add({0, h0, 0}, r, 2600);
    DemParams p = dem01_params(c[0], e);
    p.dt = min_collision_time(p, hp) / 50;
    Dem01Analytic a(r, h0, c[0], e, hp.mass[0]);
    DemSystem sys(Exec(GetParam()), p, hp);
    std::vector<double> apex;
    double prev_v = 0;
    while (apex.size() < 3 && sys.time() < 3.0) {
      sys.advance(1);
      const HostParticles o = sys.download();
      const double y = o.x[0].y, v = o.v[0].y;
      // Ballistic flight (out of contact): the apex follows exactly from (y, v).
      if (prev_v > 0 && v <= 0 && y > r) apex.push_back(y + v * v / (2 * kG));
      prev_v = v;
    }
    ASSERT_EQ(apex.size(), 3u);
    const double soft1 = r + a.vr * a.vr / (2 * kG);
    EXPECT_NEAR(apex[0], soft1, 5e-4 * soft1) << "k=" << c[0];
    for (int nb = 1; nb <= 3; ++nb) {
      const double hard = r + std::pow(e, 2 * nb) * (h0 - r);
      const double below = (hard - apex[nb - 1]) / hard;
      EXPECT_GT(below, -1e-4) << "k=" << c[0] << " bounce " << nb;
      EXPECT_LT(below, nb * c[1]) << "k=" << c[0] << " bounce " << nb;
      std::printf("[ DEM02 ] k=%g bounce %d: h=%.6f m, hard-sphere %.6f m, below by %.3f %%\n", c[0], nb,
                  apex[nb - 1], hard, 100 * below);
    }
  }
}

namespace {

// DEM03 reference: the two-degree-of-freedom system with all three contacts
// active, integrated by classical RK4 at dt = 1e-8 s (REFERENCES.md).
struct Dem03Ref {
  double m1, m2, r, H, k, eta_w1, eta_w2, eta12;
  std::array<double, 4> deriv(const std::array<double, 4>& s) const {
    const double y1 = s[0], y2 = s[1], v1 = s[2], v2 = s[3];
    const double f12 = k * (2 * r - (y2 - y1)) + eta12 * (v1 - v2);  // pushes 2 up, 1 down
    const double a1 = -kG - (k * (y1 - r) + eta_w1 * v1) / m1 - f12 / m1;
    // Upper wall overlap r - (H - y2); its force pushes particle 2 down.
    const double a2 = -kG - (k * (r - (H - y2)) + eta_w2 * v2) / m2 + f12 / m2;
    return {v1, v2, a1, a2};
  }
  // y1, y2 at the sample times ts.
  std::vector<std::array<double, 2>> run(double y1, double y2, const std::vector<double>& ts) const {
    std::array<double, 4> s{y1, y2, 0, 0};
    const double h = 1e-8;
    std::vector<std::array<double, 2>> out;
    double t = 0;
    std::size_t q = 0;
    while (q < ts.size()) {
      if (t >= ts[q] - 1e-15) {
        out.push_back({s[0], s[1]});
        ++q;
        continue;
      }
      const double step = std::min(h, ts[q] - t);
      auto add = [](const std::array<double, 4>& a, const std::array<double, 4>& b, double c) {
        return std::array<double, 4>{a[0] + c * b[0], a[1] + c * b[1], a[2] + c * b[2], a[3] + c * b[3]};
      };
      const auto k1 = deriv(s), k2 = deriv(add(s, k1, step / 2)), k3 = deriv(add(s, k2, step / 2)),
                 k4 = deriv(add(s, k3, step));
      for (int i = 0; i < 4; ++i) s[i] += step / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
      t += step;
    }
    return out;
  }
};

}  // namespace

// DEM03: both heights against the RK4 reference every dt up to 1 ms for
// e = 1.0, 0.9, 0.7, 0.5, at the production step t_c/50. Contacts never open,
// so the error is the O(dt^2) phase error of velocity Verlet,
// ~ (omega dt)^2/24 per radian, ~2e-5 of y after 1 ms: the 0.05 % target is
// well above it. The e = 1 run also reproduces the values quoted in
// REFERENCES.md (0.43201 mm at 0.103 ms, minimum 0.42334 mm near 0.170 ms,
// given to 1e-5 mm).
TEST_P(DemVerification, Dem03TwoStackedParticles) {
  const double r = 0.5e-3, H = 1.8e-3, k = 1e3;
  for (double e : {1.0, 0.9, 0.7, 0.5}) {
    for (ForcePath path : {ForcePath::Particle, ForcePath::Pair}) {
      HostParticles hp;
      hp.add({0, 0.45e-3, 0}, r, 2.0e4);
      hp.add({0, 1.35e-3, 0}, r, 1.0e4);
      DemParams p;
      p.lo = {-2e-3, -1e-3, -2e-3};
      p.hi = {2e-3, 3e-3, 2e-3};
      p.walls = {Wall{{0, 0, 0}, {0, 1, 0}}, Wall{{0, H, 0}, {0, -1, 0}}};
      p.material = simple_material(k, e);
      p.gravity = {0, -kG, 0};
      p.path = path;
      p.dt = min_collision_time(p, hp) / 50;
      const long nsteps = static_cast<long>(std::ceil(1e-3 / p.dt));
      std::vector<double> ts;
      for (long s = 1; s <= nsteps; ++s) ts.push_back(s * p.dt);
      const double b = damping_ratio_from_restitution(e);
      const double m1 = hp.mass[0], m2 = hp.mass[1];
      Dem03Ref ref{m1, m2, r, H, k, 2 * b * std::sqrt(k * m1), 2 * b * std::sqrt(k * m2),
                   2 * b * std::sqrt(k * m1 * m2 / (m1 + m2))};
      const auto yr = ref.run(0.45e-3, 1.35e-3, ts);
      DemSystem sys(Exec(GetParam()), p, hp);
      double worst = 0;
      for (long s = 0; s < nsteps; ++s) {
        sys.advance(1);
        const HostParticles o = sys.download();
        const int i1 = o.id[0] == 0 ? 0 : 1, i2 = 1 - i1;
        worst = std::max({worst, std::fabs(o.x[i1].y - yr[s][0]) / yr[s][0], std::fabs(o.x[i2].y - yr[s][1]) / yr[s][1]});
      }
      EXPECT_LT(worst, 5e-4) << "e=" << e << " path " << to_string(path);
      if (path == ForcePath::Particle)
        std::printf("[ DEM03 ] e=%.1f dt=t_c/50 (%ld steps): worst relative error vs RK4 %.3e\n", e, nsteps, worst);
      if (e == 1.0 && path == ForcePath::Particle) {
        const auto q = ref.run(0.45e-3, 1.35e-3, {0.103e-3});
        // Quoted as 0.43201 mm; our RK4 (step 1e-8 and 1e-9 agree to 1e-12 m)
        // gives 0.431982 mm: 3e-5 mm apart, consistent with the time 0.103 ms
        // being rounded (dy/dt there is ~0.3 mm/ms). Tolerance 5e-8 m.
        EXPECT_NEAR(q[0][0], 0.43201e-3, 5e-8);
        std::vector<double> fine;
        for (int i = 0; i <= 400; ++i) fine.push_back(0.12e-3 + i * 0.25e-6);
        const auto yy = ref.run(0.45e-3, 1.35e-3, fine);
        double ymin = 1;
        double tmin = 0;
        for (std::size_t i = 0; i < yy.size(); ++i)
          if (yy[i][0] < ymin) { ymin = yy[i][0]; tmin = fine[i]; }
        EXPECT_NEAR(ymin, 0.42334e-3, 1e-8);
        EXPECT_NEAR(tmin, 0.170e-3, 1e-5);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(All, DemVerification, ::testing::ValuesIn(lbdem::test::backends()),
                         lbdem::test::backend_name);
