// The fluidized_bed scene's checkpoint (cfd/checkpoint.hpp).
#include "cfd/checkpoint.hpp"

#include "cfd/gas_solver.hpp"
#include "dem/system.hpp"

namespace lbdem::cfd {

using halo::load_run;
using halo::save_run;

void save_bed(ckpt::Writer& w, const GasSolver& gas, const dem::DemSystem& dem, const RunValues& values) {
  save_run(w, values);
  w.section("gas");
  gas.save_state(w);
  w.section("dem");
  dem.save_state(w);
}

RunValues load_bed(ckpt::Reader& r, GasSolver& gas, dem::DemSystem& dem) {
  RunValues v = load_run(r);
  r.section("gas");
  gas.load_state(r);
  r.section("dem");
  dem.load_state(r);
  r.finish();
  return v;
}

}  // namespace lbdem::cfd
