// The SI sections of a fluid scene (lbm/fluid_reader.hpp).
#include "lbm/fluid_reader.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/buffer.hpp"
#include "core/error.hpp"
#include "core/run_checks.hpp"
#include "lbm/distributed_fluid.hpp"
#include "lbm/tau.hpp"

namespace lbdem::lbm {

SiFluid read_si_fluid(const Config& root, LbmSetup& s) {
  SiFluid f;
  const int D = s.lattice == LatticeKind::D2Q9 ? 2 : 3;
  const Config coll = root.section("collision");
  s.collision = coll.choice("model", "trt", {"bgk", "trt"}) == "bgk" ? CollisionKind::BGK : CollisionKind::TRT;
  s.magic = coll.number_in("magic", 3.0 / 16.0, 1e-6, 100.0, "TRT magic parameter Lambda; 3/16 exact walls, 1/4 most stable");
  if (coll.has("tau")) f.tau = coll.number("tau");
  coll.accept("tau");
  coll.finish();

  const Config fluid = root.section("fluid");
  f.rho = fluid.positive("density");
  f.nu = fluid.positive("kinematic_viscosity");
  fluid.finish();

  const Config dom = root.section("domain");
  f.cells = dom.integers("cells", static_cast<std::size_t>(D), static_cast<std::size_t>(D), 1, 1L << 16);
  f.dx = dom.positive("spacing");
  dom.finish();

  const Config time = root.section("time");
  if (time.has("dt")) f.dt = time.positive("dt");
  time.accept("dt");
  f.length = read_run_length(time, 1, 1000000000000L);
  time.finish();
  return f;
}

Units si_fluid_units(const Config& root, const SiFluid& f, double u_ref, double max_mach, LbmSetup& s) {
  UnitsRequest ur;
  ur.dx = f.dx;
  ur.nu = f.nu;
  ur.rho = f.rho;
  ur.tau = f.tau;
  ur.dt = f.dt;
  ur.u_ref = u_ref;
  ur.max_mach = max_mach;
  ur.where = root.source();
  const Units U = derive_units(ur);
  s.tau = U.tau;
  if (bgk_too_close_to_half(s.collision, s.tau))
    throw ConfigError(root.source() + ": key 'collision.tau' = " + std::to_string(s.tau) +
                      ": BGK is unstable this close to 0.5; use tau >= 0.51 or collision.model: trt");
  return U;
}

long si_fluid_steps(const SiFluid& f, const Units& U) {
  if (f.length.end) return std::max<long>(1, saturating_steps(std::round(*f.length.end / U.dt)));
  return f.length.steps.value_or(0);
}

void check_fluid_memory(const LbmSetup& s, const halo::ParallelOptions& po, int ranks, Backend backend) {
  const std::size_t need = distributed_fluid_memory(s, po, ranks);
  const auto cells = static_cast<std::size_t>(s.domain.storage_cells());
  const std::size_t host_need = cells * (1 + 5 * sizeof(double)) + (backend == Backend::Host ? need : 0);
  const std::size_t have = backend_free_bytes(backend);
  const std::size_t host_have = backend_free_bytes(Backend::Host);
  if (need > have || host_need > host_have) {
    const bool dev = need > have;
    throw ResourceError("key 'domain.cells': the grid of " + std::to_string(cells) + " cells needs " +
                        std::to_string((dev ? need : host_need) >> 20) + " MiB of " + (dev ? to_string(backend) : "host") +
                        " memory but " + std::to_string((dev ? have : host_have) >> 20) +
                        " MiB are free; use fewer cells, precision: fp32, or streaming: aa");
  }
}

}  // namespace lbdem::lbm
