#pragma once
// The record of a rebuild-decision report, reduced on the device by the
// integration kernels and read by RebuildScheduler on the host.
#include <cstdint>

#include "atomics.hpp"
#include "core/hd.hpp"
#include "dem/particle_view.hpp"

namespace lbdem::dem {

// What the host needs for its rebuild decisions (RebuildScheduler), reduced
// over the particles on the device and copied to the host asynchronously.
// Values are squares, as float bits rounded up (detail::float_bits_up), so
// that an integer atomic max reduces them.
struct StatusRecord {
  std::uint32_t disp2 = 0;   // max |x - x0|^2 at the report step (x0: position at the last build) [m^2]
  std::uint32_t speed2 = 0;  // max |v|^2 (the velocity of the report step's drift) [m^2/s^2]
  std::uint32_t accel2 = 0;  // max |F/m|^2 (the force of its kick, all contributions) [m^2/s^4]
  // Largest |x - x0|^2 above (skin/2)^2 seen at a step that did not rebuild,
  // since the previous report; 0: none. Lookahead: the list was stale (an
  // error); every-step check: the rebuild request of this step.
  std::uint32_t over2 = 0;
};

// One particle's contribution to a report.
LBDEM_HD LBDEM_FORCEINLINE void report_particle(StatusRecord* rec, double d2, const Real4& v, const Real4& f) {
  const double a2 = (f.x * f.x + f.y * f.y + f.z * f.z) * (v.w * v.w);  // v.w = 1/m
  detail::atomic_max_u32(&rec->disp2, detail::float_bits_up(d2));
  detail::atomic_max_u32(&rec->speed2, detail::float_bits_up(v.x * v.x + v.y * v.y + v.z * v.z));
  detail::atomic_max_u32(&rec->accel2, detail::float_bits_up(a2));
}

}  // namespace lbdem::dem
