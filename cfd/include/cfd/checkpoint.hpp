#pragma once
// The fluidized_bed scene's checkpoint on one rank: run, gas
// (GasSolver::save_state), dem (DemSystem::save_state).
#include "core/checkpoint.hpp"
#include "halo/shared_checkpoint.hpp"

namespace lbdem::dem {
class DemSystem;
}

namespace lbdem::cfd {

class GasSolver;
using halo::RunValues;

void save_bed(ckpt::Writer& w, const GasSolver& gas, const dem::DemSystem& dem, const RunValues& values);
RunValues load_bed(ckpt::Reader& r, GasSolver& gas, dem::DemSystem& dem);

}  // namespace lbdem::cfd
