#pragma once
// One particle snapshot (particles.xdmf / particles_<step>.h5) from host
// particles, shared by the scenes that move particles (dem, particles).
#include <string>
#include <vector>

#include "core/output.hpp"
#include "core/piece_output.hpp"
#include "dem/particles.hpp"

namespace lbdem::dem {

// x, y, z of each vector, interleaved (3 n values).
inline std::vector<double> interleave(const std::vector<Vec3d>& v) {
  std::vector<double> out(3 * v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + static_cast<std::size_t>(k)] = v[i][k];
  return out;
}

// The datasets of a particle snapshot: positions, then radius, velocity,
// angular velocity, id and mass of `h`, then the scene's own per-particle
// fields `extra` (same storage order as `h`). `fields` points into the
// buffers held here, so the object is neither copied nor moved.
struct ParticleDatasets {
  std::vector<double> pos, vel, omg, id;
  std::vector<io::ParticleField> fields;
  ParticleDatasets(const HostParticles& h, const std::vector<io::ParticleField>& extra)
      : pos(interleave(h.x)), vel(interleave(h.v)), omg(interleave(h.w)), id(h.id.begin(), h.id.end()) {
    fields = {{"radius", 1, h.r.data()}, {"velocity", 3, vel.data()}, {"angular_velocity", 3, omg.data()},
              {"id", 1, id.data()}, {"mass", 1, h.mass.data()}};
    fields.insert(fields.end(), extra.begin(), extra.end());
  }
  ParticleDatasets(const ParticleDatasets&) = delete;
  ParticleDatasets& operator=(const ParticleDatasets&) = delete;
};

// Writes the snapshot of `h` (ParticleDatasets) through one writer.
inline void write_particle_snapshot(io::ParticleWriter& w, long step, double time, const HostParticles& h,
                                    const std::vector<io::ParticleField>& extra = {}) {
  const ParticleDatasets d(h, extra);
  w.write(step, time, h.size(), d.pos.data(), d.fields);
}

// This rank's piece of a particle snapshot (core/piece_output.hpp): the same
// datasets as write_particle_snapshot for the particles `h` the rank owns.
// Returns the (name, components) of every field, for the index.
inline std::vector<std::pair<std::string, int>> write_particle_piece(io::PieceParticleWriter& w, long step, double time,
                                                                     const HostParticles& h,
                                                                     const std::vector<io::ParticleField>& extra = {}) {
  const ParticleDatasets d(h, extra);
  w.write_piece(step, time, h.size(), d.pos.data(), d.fields);
  std::vector<std::pair<std::string, int>> names;
  for (const auto& f : d.fields) names.emplace_back(f.name, f.components);
  return names;
}

}  // namespace lbdem::dem
