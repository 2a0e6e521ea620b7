// The wall-case drivers of lbdem_bench_psm (bench/imb/wall_cases.hpp): the
// tube's exact cell cover, and tiny instances of both cases (d/l 4, the
// coarsest sphere the fixed-sphere map covers) against the published wall
// corrections; the start-up of a free sphere from rest
// (bench/imb/startup_case.hpp) against the unsteady Stokes references.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "../../bench/imb/startup_case.hpp"
#include "../../bench/imb/wall_cases.hpp"
#include "imb/wall_lubrication.hpp"

using namespace lbdem;

// The cell cover of a circle: a quarter circle's area, a square wholly inside
// and wholly outside, and the cells of a grid summing to pi R^2 (each cell's
// area is exact, so the sum is to round-off), against a midpoint-rule count.
TEST(WallCases, RectCircleAreaIsExact) {
  const double R = 7.3;
  EXPECT_NEAR(bench::rect_circle_area(0, R, 0, R, R), M_PI * R * R / 4, 1e-12);
  EXPECT_NEAR(bench::rect_circle_area(-1, 1, -1, 1, R), 4.0, 1e-12);
  EXPECT_EQ(bench::rect_circle_area(R, R + 1, 0, 1, R), 0.0);
  double sum = 0;
  for (int y = -9; y < 9; ++y)
    for (int x = -9; x < 9; ++x) sum += bench::rect_circle_area(x, x + 1, y, y + 1, R);
  EXPECT_NEAR(sum, M_PI * R * R, 1e-10);
  // One boundary cell against a 2000^2 midpoint count (error ~ perimeter / n^2 ~ 1e-6).
  const double x0 = 5.2, y0 = 4.1;
  const int n = 2000;
  long in = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = x0 + (i + 0.5) / n, y = y0 + (j + 0.5) / n;
      in += x * x + y * y <= R * R;
    }
  EXPECT_NEAR(bench::rect_circle_area(x0, x0 + 1, y0, y0 + 1, R), double(in) / (double(n) * n), 1e-5);
}

// A sphere of d/l 4 approaching the wall of a 24^3 box (tau 0.8, the default
// weighting and Lambda): the drag exceeds Stokes's and grows as the gap
// shrinks, and the ratio of the drags at gaps 1 and 4 cells (h/a 1.5 and 3)
// is within 8 % of Brenner's lambda(1.5) / lambda(3) = 2.043: the d/l 4 bar
// of the fixed-sphere map (half the first paper's Table 1 error). The ratio
// divides the sphere's own drag error out; measured -4.5 % on the host (the
// top wall and the lateral images, screened by the near wall, move it by
// < 0.1 % from this box to 48^3).
TEST(WallCases, BrennerTinyBox) {
  bench::WallCaseSpec s;
  s.diameter = 4;
  s.tolerance = 1e-4;
  const auto r1 = bench::run_brenner(s, 24, 24, 1, Backend::Host);
  const auto r4 = bench::run_brenner(s, 24, 24, 4, Backend::Host);
  ASSERT_TRUE(r1.run.converged && r4.run.converged);
  const double l1 = r1.F / r1.F_stokes, l4 = r4.F / r4.F_stokes;
  EXPECT_GT(l4, 1.1);  // Brenner at h/a 3: 1.569 (the sphere's own error at d/l 4 is a few %)
  EXPECT_GT(l1, l4 + 1.0);
  EXPECT_NEAR(r1.lambda, 3.2054, 1e-3);
  EXPECT_NEAR(r4.lambda, 1.5692, 1e-3);
  EXPECT_NEAR((l1 / l4) / (r1.lambda / r4.lambda), 1.0, 0.08) << l1 / l4 << " against " << r1.lambda / r4.lambda;
  // The gap correction (imb/wall_lubrication.hpp) is fitted at the rule's
  // Lambda 0.06-0.17; d/l 4's (0.011 at tau 0.8) is outside it: no correction.
  EXPECT_EQ(r1.lubrication, 0.0);
  EXPECT_EQ(r4.lubrication, 0.0);
}

// The gap correction where it was fitted: d/l 6 at gaps of one and two cells
// (box 32^3, tau 0.8, the default weighting and Lambda), added by the
// engine's kernel (psm.wall_lubrication: on, imb::add_wall_lubrication) to
// the gathered force as the coupled step adds it. The ratio of the two drags
// divides the sphere's own error out. Bare, the ratio misses Brenner's
// lambda(4/3) / lambda(5/3) = 1.5964 by -5.8 % (the one-cell gap carries too
// much flux, imb/wall_lubrication.hpp); corrected within 0.1 % on the host.
// The 1.5 % tolerance is half the 3 % bar (each drag within 1.5 %
// leaves the ratio within 3 %). Each corrected drag over the same sphere's
// unbounded drag (its chi 0.25 array K over Sangani & Acrivos's) is within the
// 3 % bar of Brenner's lambda (measured -0.2 % on the host, NOTES.md), and the
// engine's force is the bare force plus the bench's correction, 6 pi mu a U
// c a g^-p, to 1e-12.
TEST(WallCases, GapCorrectionDl6) {
  bench::WallCaseSpec s;
  s.diameter = 6;
  s.tolerance = 1e-5;
  s.engine_lubrication = true;
  const auto r1 = bench::run_brenner(s, 32, 32, 1, Backend::Host);
  const auto r2 = bench::run_brenner(s, 32, 32, 2, Backend::Host);
  ASSERT_TRUE(r1.run.converged && r2.run.converged);
  ASSERT_TRUE(r1.engine.applied) << r1.engine.note;
  const double l1 = r1.F / r1.F_stokes, l2 = r2.F / r2.F_stokes;
  const double ref = r1.lambda / r2.lambda;
  EXPECT_NEAR(ref, 1.5964, 1e-3);
  EXPECT_LT(l1 / l2 / ref, 0.97) << "the bare ratio: the gap's deficit this correction is for";
  for (const auto* r : {&r1, &r2})
    EXPECT_NEAR(r->F_engine - r->F, r->F_stokes * r->lubrication, 1e-12 * r->F_stokes * r->lubrication);
  const double e1 = r1.F_engine / r1.F_stokes, e2 = r2.F_engine / r2.F_stokes;
  EXPECT_NEAR(e1 / e2 / ref, 1.0, 0.015) << e1 / e2 << " against " << ref;
  const double unb = bench::unbounded_factor(s, 0.25, Backend::Host);
  EXPECT_NEAR(unb, 0.9906, 2e-3);  // the harness at d/l 6, tau 0.8 (NOTES.md)
  for (const auto* r : {&r1, &r2}) {
    std::printf("d/l 6, h/a %.4f: F/F_inf %.5f bare (%+.2f %%), %.5f with the engine's correction (%+.2f %%), Brenner "
                "%.5f; %ld steps\n",
                r->h_over_a, r->F / r->F_stokes / unb, 100 * (r->F / r->F_stokes / unb / r->lambda - 1),
                r->F_engine / r->F_stokes / unb, 100 * (r->F_engine / r->F_stokes / unb / r->lambda - 1), r->lambda,
                r->run.steps);
    EXPECT_NEAR(r->F_engine / r->F_stokes / unb / r->lambda, 1.0, 0.03) << "gap h/a " << r->h_over_a;
    EXPECT_LT(r->F / r->F_stokes / unb / r->lambda, 0.99) << "bare, gap h/a " << r->h_over_a;
  }
}

// The engine's correction in the wall benchmark on a small box, unconverged
// (300 steps): whatever the drag, the engine adds exactly the bench's
// correction force F_Stokes c a g^-p (to 1e-12), and the bare force is the
// run without it bit for bit (the steady-state watch reads the bare force).
// The box is 20 cells high so that the top wall is beyond the fit's 8 cells
// (the bench corrects for the near wall only; the engine for every wall).
// d/l 4 (the rule's Lambda 0.011 at tau 0.8) is outside the fit: nothing added.
TEST(WallCases, EngineCorrectionIsTheBenchCorrection) {
  bench::WallCaseSpec s;
  s.diameter = 6;
  s.max_steps = 300;
  s.check = 50;
  const auto bare = bench::run_brenner(s, 16, 20, 1.25, Backend::Host);
  s.engine_lubrication = true;
  const auto eng = bench::run_brenner(s, 16, 20, 1.25, Backend::Host);
  ASSERT_TRUE(eng.engine.applied) << eng.engine.note;
  EXPECT_EQ(eng.F, bare.F);
  EXPECT_EQ(bare.F_engine, bare.F);
  EXPECT_GT(eng.lubrication, 0.1);
  EXPECT_NEAR(eng.F_engine - eng.F, eng.F_stokes * eng.lubrication, 1e-12 * eng.F_stokes * eng.lubrication);
  EXPECT_NEAR(eng.F_engine - eng.F, imb::wall_lubrication_force(eng.F_stokes / (6 * M_PI * 3 * eng.U), 3, 1.25, eng.U,
                                                                imb::psm_magic_auto(6, 0.8)),
              1e-12 * eng.F_stokes * eng.lubrication);
  s.diameter = 4;
  const auto d4 = bench::run_brenner(s, 16, 16, 1, Backend::Host);
  EXPECT_FALSE(d4.engine.applied);
  EXPECT_NE(d4.engine.note.find("NOT applied"), std::string::npos);
  EXPECT_EQ(d4.F_engine, d4.F);
}

// The correction's form: c a g^-p in units of the Stokes drag, held below
// g_min, zero for no gap, and the force along the wall normal of the sign of
// the approach speed (it resists the approach and the separation alike).
TEST(WallCases, GapCorrectionForm) {
  const imb::WallLubrication w;
  const double m = 0.17;  // the rule's Lambda at d/l 10, tau 0.8
  EXPECT_NEAR(imb::psm_magic_auto(10, 0.8), m, 1e-9);
  EXPECT_NEAR(imb::wall_lubrication_lambda(5, 1, m), w.c * 5, 1e-12);
  EXPECT_NEAR(imb::wall_lubrication_lambda(5, 2, m) / imb::wall_lubrication_lambda(5, 1, m), std::pow(2.0, -w.p), 1e-12);
  EXPECT_EQ(imb::wall_lubrication_lambda(5, 0.1, m), imb::wall_lubrication_lambda(5, w.g_min, m));
  EXPECT_EQ(imb::wall_lubrication_lambda(5, 0, m), 0.0);
  // Outside the fit's Lambda range: none (tau 0.6 and the exact-wall 3/16).
  EXPECT_EQ(imb::wall_lubrication_lambda(3, 1, imb::psm_magic_auto(6, 0.6)), 0.0);
  EXPECT_EQ(imb::wall_lubrication_lambda(3, 1, 0.1875), 0.0);
  EXPECT_GT(imb::wall_lubrication_lambda(3, 1, imb::psm_magic_auto(6, 1.0)), 0.0);
  const double mu = 0.1, U = 1e-3;
  EXPECT_NEAR(imb::wall_lubrication_force(mu, 5, 1, U, m), 6 * M_PI * mu * 5 * U * w.c * 5, 1e-15);
  EXPECT_LT(imb::wall_lubrication_force(mu, 5, 1, -U, m), 0.0);
}

// A sphere of d/l 4 on the axis of a tube with k = d/D = 0.3 (tau 0.8): the
// sphere pumps fluid along the periodic tube (Q_A > 0), the zero-flux
// combination's pressure gradient opposes it (g < 0 along the motion), and
// K = F / (3 pi mu d U) is within 8 % of Haberman & Sayre's 2.370, the d/l 4
// bar of the fixed-sphere map: K carries the sphere's own drag error, -3.3 %
// in a chi 0.25 array at this d/l and tau (measured -4.6 % raw, -1.3 % with
// that error divided out, on the host).
TEST(WallCases, TubeTiny) {
  bench::WallCaseSpec s;
  s.diameter = 4;
  s.tolerance = 1e-5;
  const auto r = bench::run_tube(s, 0.3, 2, Backend::Host);
  ASSERT_TRUE(r.a.converged && r.b.converged);
  EXPECT_LT(r.g, 0.0);
  EXPECT_GT(r.a.flux, 0.0);
  EXPECT_NEAR(r.K_ref, 2.3697, 1e-3);
  EXPECT_NEAR(r.K / r.K_ref, 1.0, 0.08) << r.K << " against " << r.K_ref;
}

// The start-up of a free sphere from rest (bench/imb/startup_case.hpp): d/l 6,
// density ratio 2, tau 0.8, the default weighting and Lambda, Re_p 0.2 at
// Stokes's terminal velocity, in a periodic cube of 5 d (30^3 cells, phi
// 0.0042), 6 e-folds of the cube's slowest viscous mode (1368 steps). The
// tolerance is the fixed-sphere map's bar at d/l 6, half the first paper's
// Table 1 error (imb::psm_drag_bar: 3.5 %): the curve's late part and the
// terminal velocity carry the sphere's drag error, the early part the
// inertia of the fluid PSM keeps inside the sphere (it moves like a sphere of
// density ratio r + 1 from T ~ 1 on; startup_case.hpp). Measured on the
// host: the curve against the periodic-cube model of density 2 RMS 0.85 %,
// max 2.3 % (T ~ 0.5, the interior fluid); against the model of density 3 for
// T >= 1 within 1.0 % (a constant offset, the drag error); the terminal slip
// against Hasimoto +0.8 %; the lab end velocity against the model +1.0 %.
// Against the unbounded reference the curve is compared over the window
// sqrt(nu t) <= L / 4 (T <= 6.2), where the images' share 2 pi T a^3 / L^3
// (the kernel's 1/(3V)) reaches 3.9 %: within the bar plus that share.
TEST(WallCases, StartupFromRestD6) {
  bench::StartupSpec s;
  s.diameter = 6;
  s.ratio = 2;
  s.box = 5;
  s.settle = 6;
  const auto r = bench::run_startup(s, Backend::Host);
  const double bar = imb::psm_drag_bar(6);
  std::printf("startup d/l 6, r 2: box model RMS %.4f max %.4f; r+1 model RMS %.4f max %.4f; unbounded (T <= %.2f) "
              "RMS %.4f max %.4f; slip %.5f Hasimoto %.5f; lab %.5f model %.5f; %.1f s\n",
              r.rms_box, r.max_box, r.rms_box_psm, r.max_box_psm, r.T_window, r.rms, r.max, r.terminal, r.hasimoto,
              r.lab_end, r.lab_box, r.seconds);
  ASSERT_EQ(r.L, 30);
  ASSERT_GT(r.samples.size(), 100u);
  EXPECT_LT(r.late_change, 2e-3);  // steady at the end
  EXPECT_LT(r.rms_box, bar);
  EXPECT_LT(r.max_box, bar);
  double late_psm = 0;
  for (const auto& q : r.samples)
    if (q.T >= 1) late_psm = std::max(late_psm, std::abs(q.u_psm - q.box_psm));
  EXPECT_LT(late_psm, bar);
  EXPECT_NEAR(r.terminal / r.hasimoto, 1.0, bar);
  EXPECT_NEAR(r.lab_end / r.lab_box, 1.0, bar);
  EXPECT_LT(r.max, bar + 2 * M_PI * r.T_window / std::pow(r.L / r.a, 3));
  // The curve rises: the sphere is not held (a free particle, F pulls it along +x).
  EXPECT_GT(r.samples.back().u, 0.9);
}
