// Checks of a coupled particle scene (imb/coupled_memory.hpp).
#include "imb/coupled_memory.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/run_checks.hpp"
#include "dem/particle_checks.hpp"
#include "halo/comm.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/snapshot_pack.hpp"
#include "lbm/fluid_checks.hpp"

namespace lbdem::imb {

using checks::num;
using dem::kDemDeviceBytesPerParticle;
using dem::kDemHostBytesPerParticle;
using lbm::lbm_grid_bytes;
using lbm::or_fp32;
using lbm::rank_fluid;

namespace {
std::int64_t id_of(const dem::HostParticles& p, std::size_t i) {
  return i < p.id.size() ? p.id[i] : static_cast<std::int64_t>(i);
}
}  // namespace

void check_particles_mach(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                          const dem::HostParticles& p, const CoupledParams& cp, double max_mach) {
  if (!(fluid.tau > 0.5) || p.x.empty()) return;
  const double fluid_density = cp.fluid_density;
  const auto& gravity = cp.gravity;
  const CoupledScales s = coupled_scales(fluid, dem, p, cp);
  if (!(s.mach > max_mach)) return;
  const double u_max = max_mach / std::sqrt(3.0);
  std::string head = root.source() + ": lattice Mach number u sqrt(3) = " + num(s.mach) + " exceeds " +
                     num(max_mach) + " (the weakly compressible LBM with PSM diverges beyond it): ";
  if (s.u_ref == s.settling_speed && s.settling_id >= 0) {
    std::size_t i = 0;
    while (i < p.x.size() && id_of(p, i) != s.settling_id) ++i;
    if (i == p.x.size()) i = 0;
    const double d = 2 * p.r[i], m = p.mass[i];
    const double g = std::sqrt(gravity[0] * gravity[0] + gravity[1] * gravity[1] + gravity[2] * gravity[2]);
    // Largest |g| and smallest tau with a settling speed within the limit
    // (the terminal speed grows with g and falls with the viscosity).
    double glo = 0, ghi = g;
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (glo + ghi);
      (terminal_speed(d, m, fluid_density, s.nu, mid) <= u_max ? glo : ghi) = mid;
    }
    double tlo = fluid.tau, thi = fluid.tau;
    while (terminal_speed(d, m, fluid_density, (thi - 0.5) / 3.0, g) > u_max && thi < 1e6) thi = 0.5 + 2 * (thi - 0.5);
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (tlo + thi);
      (terminal_speed(d, m, fluid_density, (mid - 0.5) / 3.0, g) > u_max ? tlo : thi) = mid;
    }
    std::string tau_way = thi <= 5.0 ? "raise fluid.tau to at least " + num(thi) + " (a more viscous fluid settles it slower)"
                                     : "fluid.tau would have to exceed its limit 5";
    throw ConfigError(head + "particle id " + std::to_string(s.settling_id) + " would settle at about " +
                      num(s.settling_speed) + " cells per step under " + cp.keys.gravity +
                      " (Schiller-Naumann terminal speed). Any one of: lower |" + cp.keys.gravity + "| to at most " +
                      num(glo) + " (lattice units; it scales with dt^2, so a smaller lattice time step lowers it); " +
                      tau_way + "; a lower " + cp.keys.density + "; a finer grid (a larger particles.diameter in "
                      "cells for the same particle lowers the lattice speeds)");
  }
  if (s.u_ref == s.particle_speed) {
    throw ConfigError(head + "particle id " + std::to_string(s.fastest_id) + " starts at |v| + |w| r = " +
                      num(s.particle_speed) + " cells per step (particles.velocity, particles.angular_velocity). "
                      "Any one of: lower them so that |v| + |w| r <= " + num(u_max) +
                      "; a smaller lattice time step (velocities scale with dt, gravity with dt^2, tau - 1/2 with dt); "
                      "a finer grid (a larger particles.diameter in cells for the same particle)");
  }
  throw ConfigError(head + "a boundary moves at " + num(s.wall_speed) + " cells per step; keep it below " + num(u_max));
}

// DEM device memory of a coupled scene per particle, an upper bound from the
// DEM's layout (dem/src/particle_store.hpp, neighbour_list.hpp): 23 records
// of 32 bytes (state, its reorder copy, previous forces and velocities,
// coupling input) plus id and type twice; eight ints of sort and list
// bookkeeping; and the neighbour list at its first capacity of 32 slots
// (fitted down after the first build), each an index and a tangential
// history (24 bytes) and their copies from the previous build. The cell
// grid of the DEM (a few bytes per particle cell) is not counted.
constexpr double kCoupledDemBytesPerParticle = 23 * 32 + 2 * (8 + 4) + 8 * 4 + 32 * 2 * (4 + 24);

MemoryUse coupled_memory(const lbm::LbmSetup& fluid, const CoupledParams& cp, double particles, Backend b,
                         SnapshotMemory snapshots) {
  const auto n = static_cast<Index>(std::max(0.0, std::ceil(particles)));
  MemoryUse m = lbm::lbm_memory(fluid);
  m.add(psm_memory(fluid, cp.slots, cp.psm, n, b == Backend::Cuda));
  if (n > 0)
    m.add("DEM particles and lists", static_cast<std::size_t>(static_cast<double>(n) * kCoupledDemBytesPerParticle));
  if (snapshots.background) {
    const std::size_t pack = SnapshotPack::device_bytes(b, fluid.domain.owned().size(), snapshots.fp32);
    if (pack > 0) m.add("snapshot pack (output.background)", pack);
  }
  return m;
}

void check_coupled_memory(const Config& root, const lbm::LbmSetup& fluid, const CoupledParams& cp,
                          double particles, Backend b, SnapshotMemory snapshots) {
  double cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
  // The device holds this rank's piece, and so does the host set-up (flags,
  // rho, u of the piece: DistributedFluid::initialize_uniform); every rank may
  // read every particle (a list in the case file).
  const lbm::LbmSetup mine = rank_fluid(root, fluid);
  const double piece_cells = static_cast<double>(mine.domain.storage_cells());
  // Absurd sizes first, in double (the exact sum below is in 64-bit integers).
  const std::string keys = cp.keys.cells + ", particles";
  check_memory(root, b, lbm_grid_bytes(mine, piece_cells) + particles * kDemDeviceBytesPerParticle,
               piece_cells * (1 + 4 * sizeof(double)) + particles * kDemHostBytesPerParticle, keys,
               "the grid of " + num(cells) + " cells with " + num(particles) + " particles",
               "use fewer cells or particles" + or_fp32(fluid));
  const MemoryUse m = coupled_memory(mine, cp, particles, b, snapshots);
  // Background snapshots keep the owned box's fields in host memory too.
  const double pinned =
      snapshots.background ? static_cast<double>(SnapshotPack::host_bytes(mine.domain.owned().size(), snapshots.fp32)) : 0.0;
  std::vector<MemoryItem> big = m.items;
  std::sort(big.begin(), big.end(), [](const MemoryItem& x, const MemoryItem& y) { return x.bytes > y.bytes; });
  std::string parts;
  for (std::size_t i = 0; i < big.size() && i < 3; ++i)
    parts += (i ? ", " : "") + big[i].name + " " + num(static_cast<double>(big[i].bytes) / piece_cells) + " B/cell";
  // Host: the set-up fields of the piece (flag byte, rho, u per cell) and the particles' host copies.
  check_memory(root, b, static_cast<double>(m.total()),
               piece_cells * (1 + 4 * sizeof(double)) + particles * kDemHostBytesPerParticle + pinned,
               snapshots.background ? keys + ", output.background" : keys,
               "the grid of " + num(cells) + " cells with " + num(particles) + " particles (" +
                   num(static_cast<double>(m.total()) / piece_cells) + " B/cell: " + parts + ")" +
                   (mine.domain.storage_cells() < fluid.domain.storage_cells()
                        ? " on each of " + std::to_string(halo::Comm::world().size()) + " ranks"
                        : std::string()),
               "use fewer cells or particles" + or_fp32(fluid));
}

}  // namespace lbdem::imb
