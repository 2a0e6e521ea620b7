#pragma once
// Small kernel bodies shared by the slot map (cell_slots.cu) and the tile map
// (tile_map.cu).
#include "core/algorithms.hpp"
#include "core/exec.hpp"
#include "imb/particle_view.hpp"

namespace lbdem::imb::mapk {

struct ZeroInts {
  int* p;
  LBDEM_HD void operator()(Index i) const { p[i] = 0; }
};

struct ParticleRadius {
  const double* r;
  int stride;
  LBDEM_HD double operator()(Index i) const { return r[i * stride]; }
};
struct MaxOp {
  LBDEM_HD double operator()(double a, double b) const { return a > b ? a : b; }
};

// Largest radius of the particles (a synchronous reduction on the backend).
inline double largest_radius(const Exec& ex, const SphereView& p, Scratch& scratch) {
  return transform_reduce(ex, p.n, 0.0, MaxOp{}, ParticleRadius{p.r, p.stride}, scratch);
}

}  // namespace lbdem::imb::mapk
