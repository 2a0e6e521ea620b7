#pragma once
// The particles' checkpoint: the one-rank raw section (DemSystem::save_state)
// and its collective form (halo/shared_checkpoint.hpp writes and reads the
// file).
//
// Particles: section "dem.<k>" (chunked) holds rank k's DemSystem::save_state.
// The same rank count and cut: each rank loads its own (bit for bit). Any
// other: rank 0 turns every section into portable particle records
// (DemSystem::saved_particles) and broadcasts them; each rank keeps those in
// its piece and rebuilds (DemSystem::restore_particles; to round-off, bitwise
// where contacts are summed in global-id order).
#include <string>

#include "core/checkpoint.hpp"
#include "halo/shared_checkpoint.hpp"

namespace lbdem::dem {

class DemSystem;
using halo::RunValues;

// Sections of the dem scene on one rank: run, dem.
void save_dem(ckpt::Writer& w, const DemSystem& dem, const RunValues& values);
RunValues load_dem(ckpt::Reader& r, DemSystem& dem);

// Sections of the dem scene on every rank: the raw one-rank path on one
// rank; else "run" and each rank's DemSystem::save_state ("dem.<k>",
// chunked). Collective.
void save_dem(ckpt::Run& run, const halo::Comm& comm, long step, double time, const DemSystem& dem,
              const RunValues& values);
// Loads the dem scene's checkpoint on every rank (collective): the same
// rank count and decomposition `dims` (halo::Decomposition::describe) load
// each rank's raw section (bit for bit); any other reads the particles of
// every section and hands each rank those in its piece
// (DemSystem::restore_particles, to round-off).
RunValues load_dem(ckpt::Run& run, const halo::Comm& comm, DemSystem& dem, const std::string& dims);
// The particles' sections alone ("dem" or "dem.<k>"). Collective.
void load_dem_shared(ckpt::Run& run, const halo::Comm& comm, DemSystem& dem, const std::string& dims);

}  // namespace lbdem::dem
