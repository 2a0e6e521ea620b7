#pragma once
// Scenes the restart tests run on one rank (test_restart.cpp) and on several
// (test_mpi_restart.cpp).
namespace lbdem::test {

// A coupled scene with friction, walls on y, particles moving fast enough
// (0.03 cells per step against a skin of 0.4 cells) to need a neighbour-list
// rebuild in each half of the 40 steps.
inline constexpr const char* kRestartParticles = R"(scene: particles
units: lattice
domain: {cells: [20, 20, 20], periodic: [1, 0, 1]}
fluid: {tau: 0.55}
physics: {gravity: [0, -2.0e-5, 0]}
particles: {init: random, diameter: 4, density_ratio: 2, solid_fraction: 0.15, seed: 3, velocity: [0.01, -0.03, 0.006]}
dem: {stiffness: 2, restitution: 0.5, friction: 0.3, substeps: 5}
time: {steps: 40}
output: {directory: unused, interval: 20, series_interval: 10}
checkpoint: {interval: 20}
)";

// A dem scene with friction, a wall pair on y and a checkpoint at half time.
inline constexpr const char* kRestartDem = R"(scene: dem
domain: {lo: [0, 0, 0], hi: [0.01, 0.01, 0.01], periodic: [1, 0, 1]}
physics: {gravity: [0, -9.81, 0], friction: true}
material: {stiffness: 1000, restitution: 0.9, friction: 0.3}
particles: {init: random, density: 2500, radius: [0.5e-3], solid_fraction: 0.2, velocity_rms: 0.05}
time: {steps_per_collision: 50, steps: 600}
output: {directory: unused, interval: 200, series_interval: 100}
checkpoint: {interval: 300}
)";

}  // namespace lbdem::test
