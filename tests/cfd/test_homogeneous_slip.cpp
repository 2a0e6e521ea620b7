// The Wen-Yu slip of a homogeneous suspension (cfd/homogeneous_slip.hpp):
// its Stokes limit, and the drag balance at a finite Reynolds number.
#include <gtest/gtest.h>

#include <cmath>

#include "cfd/homogeneous_slip.hpp"

namespace lbdem::test {
namespace {

TEST(SuspensionWenYu, StokesLimitAndDragBalance) {
  const double phi = 0.128, d = 10, mu = 0.2462;
  // Stokes limit: w = W (1 - phi)^2.65 / (3 pi mu d).
  const double W = 1e-9;
  const double ws = W * std::pow(1 - phi, 2.65) / (3 * M_PI * mu * d);
  EXPECT_NEAR(cfd::wen_yu_slip(phi, d, 1.0, mu, W), ws, 1e-6 * ws);
  // At a finite Reynolds number the drag of the returned slip is the weight,
  // and the inertial correction makes the slip smaller than Stokes'.
  const double W2 = 0.17;  // the 3D suspension of the first paper, lattice units
  const double w = cfd::wen_yu_slip(phi, d, 1.0, mu, W2);
  EXPECT_NEAR(cfd::wen_yu_drag(phi, d, 1.0, mu, w), W2, 1e-12 * W2);
  EXPECT_LT(w, W2 * std::pow(1 - phi, 2.65) / (3 * M_PI * mu * d));
  EXPECT_GT(w, 0.9 * W2 * std::pow(1 - phi, 2.65) / (3 * M_PI * mu * d));
  EXPECT_EQ(cfd::wen_yu_slip(phi, d, 1.0, mu, 0.0), 0.0);
}

}  // namespace
}  // namespace lbdem::test
