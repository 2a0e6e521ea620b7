#pragma once
// Whole-field measures of the gas for a scene's time series and watchdog,
// taken by device reductions (core/algorithms.hpp) over the solver's fields:
// only a few scalars come back to the host, and only when a scene asks (at
// its series and check intervals, not every step).
#include "cfd/gas_solver.hpp"
#include <memory>

#include "core/exec.hpp"

namespace lbdem {
struct Scratch;
}

namespace lbdem::cfd {

struct GasMeasures {
  // Largest Courant number |u_f| dt / h over every face of the grid and its
  // normal velocity component (the explicit upwind convection is monotone
  // up to 1/2, gas_solver.hpp).
  double max_courant = 0;
  // Faces and cells whose velocity, pressure or gas fraction is not finite.
  double nonfinite = 0;
  // Gas volume fluxes eps u A through the boundary faces [m^3/s]: into and out
  // of the domain, and the rate of change of the gas volume held in the cells,
  // sum (eps - eps_old) V_c / dt. Continuity makes in - out - storage vanish
  // to the pressure solver's tolerance.
  double inflow = 0, outflow = 0, storage = 0;
  // Mean pressure [Pa] of the lowest and of the highest cell layer along z.
  double p_bottom = 0, p_top = 0;
};

class GasMonitor {
 public:
  GasMonitor(const Exec& ex);
  ~GasMonitor();
  GasMonitor(const GasMonitor&) = delete;
  GasMonitor& operator=(const GasMonitor&) = delete;
  // Synchronous (the reductions return to the host).
  GasMeasures measure(const GasSolver& gas);

 private:
  Exec ex_;
  std::unique_ptr<Scratch> scratch_;
};

}  // namespace lbdem::cfd
