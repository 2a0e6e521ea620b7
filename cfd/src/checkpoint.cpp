// The fluidized_bed scene's checkpoint (cfd/checkpoint.hpp).
#include "cfd/checkpoint.hpp"

#include "cfd/gas_solver.hpp"
#include "dem/system.hpp"

namespace lbdem::cfd {

void save_bed(ckpt::Writer& w, const GasSolver& gas, const dem::DemSystem& dem, const RunValues& values) {
  halo::save_sections(w, values, halo::section("gas", gas), halo::section("dem", dem));
}

RunValues load_bed(ckpt::Reader& r, GasSolver& gas, dem::DemSystem& dem) {
  return halo::load_sections(r, halo::section("gas", gas), halo::section("dem", dem));
}

}  // namespace lbdem::cfd
