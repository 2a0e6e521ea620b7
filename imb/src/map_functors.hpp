#pragma once
// Small kernel bodies and host helpers shared by the slot map (cell_slots.cu)
// and the tile map (tile_map.cu).
#include <algorithm>
#include <sstream>
#include <vector>

#include "core/algorithms.hpp"
#include "core/buffer.hpp"
#include "core/exec.hpp"
#include "imb/cell_slots.hpp"
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

// The map's overflow counters, after the backend's work has finished.
inline std::vector<int> read_flags(Backend b, const Buffer<int>& flags) {
  if (b == Backend::Cuda) {
#if defined(LBDEM_HAVE_CUDA)
    LBDEM_CUDA_CHECK(cudaDeviceSynchronize());
#endif
  }
  return flags.to_vector();
}

// An overflow log of (key, particle) pairs (key: a cell or a tile): the
// smallest logged key and the logged particles at it, in log order.
struct LoggedOverflow {
  Index key = -1;
  std::vector<int> particles;
};
inline LoggedOverflow read_overflow_log(const Buffer<Index>& keys, const Buffer<int>& parts, Index events,
                                        Index log_cap) {
  LoggedOverflow r;
  const Index logged = std::min<Index>(events, log_cap);
  if (logged <= 0) return r;
  std::vector<Index> k(static_cast<std::size_t>(logged));
  std::vector<int> p(static_cast<std::size_t>(logged));
  keys.copy_to_host(k.data(), logged);
  parts.copy_to_host(p.data(), logged);
  r.key = *std::min_element(k.begin(), k.end());
  for (std::size_t e = 0; e < k.size(); ++e)
    if (k[e] == r.key) r.particles.push_back(p[e]);
  return r;
}

// Ends a report: the clipped-radius note (after the overflow text, if any).
inline void finish_report(OverflowReport& r, std::ostringstream& msg) {
  if (r.radius_too_large) {
    if (r.overflow) msg << " ";
    msg << "Particle " << r.bad_particle << " is larger than MapOptions::max_radius; its cells were clipped. "
        << "Pass the true largest radius (or 0 to compute it).";
  }
  r.message = msg.str();
}

}  // namespace lbdem::imb::mapk
