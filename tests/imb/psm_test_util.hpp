#pragma once
// Fixed-sphere drag in a periodic simple cubic array (PSM), for tests and benchmarks.
#include <cmath>
#include <vector>

#include "core/buffer.hpp"
#include "imb/psm_coupling.hpp"
#include "lbm/solver.hpp"

namespace lbdem::test {

// Sangani & Acrivos (1982) Eq. 60 (../shared/REFERENCES.md), chi = d/L <= 0.75.
inline double sangani_acrivos_K(double chi) {
  static const double q[31] = {1.000000,  1.418649,   2.012564,  2.331523,  2.564809,  2.584787,  2.873609, 3.340163,
                               3.536763,  3.504092,   3.253622,  2.689757,  2.037769,  1.809341,  1.877347, 1.534685,
                               0.9034708, 0.2857896,  -0.5512626, -1.278724, 1.013350,  5.492491,  4.615388, -0.5736023,
                               -2.865924, -4.709215, -6.870076, 0.1455304, 12.51891,  9.742811,  -5.566269};
  double K = 0, p = 1;
  for (double c : q) {
    K += c * p;
    p *= chi;
  }
  return K;
}

struct SphereDrag {
  double K = 0, K_ref = 0, rel_error = 0;
  double force = 0, mean_u = 0;
  long steps = 0;
  double seconds = 0;
};

struct SphereCase {
  double diameter = 10;  // lattice units (d/l)
  double chi = 0.5;      // d / L
  double tau = 0.8;
  lbm::CollisionKind collision = lbm::CollisionKind::TRT;
  double magic = 3.0 / 16.0;
  lbm::Precision precision = lbm::Precision::FP64;
  imb::FractionMethod method = imb::FractionMethod::Exact;
  imb::PsmVariant variant = imb::PsmVariant::NEBB;
  imb::PsmWeight weight = imb::PsmWeight::NobleTorczynski;
  double tolerance = 1e-6;  // steady state: relative change of the force per check
  long max_steps = 200000;
  const imb::FractionTable* table = nullptr;
};

// Drives the fluid with a body force g (lattice units) past a fixed sphere at
// the centre of an L^3 periodic box; returns K = F / (6 pi mu a U), U the
// mean velocity over the whole cell (solid included, the fluid fraction
// weighting each cell's velocity).
SphereDrag fixed_sphere_drag(const SphereCase& c, Backend b);

}  // namespace lbdem::test
