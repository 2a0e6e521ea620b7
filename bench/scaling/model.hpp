#pragma once
// A performance model of the fluid (and coupled PSM) step on many GPUs.
//
// Time per step of one rank =
//   compute   cells / R(cells) (R: the measured single-GPU cell rate at that
//             sub-domain size, interpolated in log(cells)) + the cost of
//             splitting the step into outer slabs and an inner box (kernel
//             launches; on a GPU shared by several ranks, a fitted factor);
// + exposed communication: the halo bytes and messages of each neighbour
//             link, counted the way lbm::halo_links packs them, sent over
//             the link kind the two ranks share (NVLink in a node, InfiniBand
//             between nodes, PCIe for host staging), minus what the overlap
//             hides behind the inner box (a fitted efficiency);
// + particles (coupled suspension): the PSM cost per cell times the particle
//             load imbalance, the DEM step, and the ghost / migration /
//             force-return messages, none of them overlapped.
// The step of the slowest rank is the step of the run. Plain C++: no GPU.
// Constants marked Assumed that calibrate() fits become Fitted there.
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "halo/decomposition.hpp"

namespace lbdem::scaling_model {

enum class Transport { HostMpi, DeviceMpi, Nccl };
const char* to_string(Transport t);
Transport parse_transport(const std::string& s, const std::string& key);

// Where a parameter comes from (reported with its value).
enum class Source { Measured, DataSheet, Fitted, Assumed };
const char* to_string(Source s);

struct Param {
  double value = 0;
  Source source = Source::Assumed;
  std::string note;
};

// The machine: links, latencies and the fitted constants of the code's
// exchange. Bandwidths in bytes/s per direction, times in seconds.
struct Machine {
  int gpus_per_node = 8;
  Param nvlink_Bps{450e9, Source::DataSheet, "NVLink 4, per GPU per direction (H100/H200 SXM)"};
  Param ib_node_Bps{100e9, Source::DataSheet, "4 x 200 Gb/s InfiniBand per node, per direction"};
  Param pcie_Bps{55e9, Source::DataSheet, "PCIe 5 x16, effective, per direction"};
  Param copy_Bps{3.0e12, Source::Measured, "device copy bandwidth (pack/unpack kernels)"};
  Param host_mpi_Bps{12e9, Source::Assumed, "MPI between pinned host buffers of one node"};
  Param lat_mpi_s{3e-6, Source::Assumed, "MPI message latency, intra-node"};
  Param lat_ib_s{5e-6, Source::Assumed, "MPI / GPUDirect message latency over InfiniBand"};
  Param lat_nccl_s{15e-6, Source::Assumed, "NCCL send/recv per peer (one group per exchange)"};
  Param launch_s{4e-6, Source::Assumed, "one extra kernel launch on the step's critical path"};
  Param fixed_host_s{0.2e-3, Source::Assumed, "host-staged exchange: stream waits, staging, MPI progress"};
  Param fixed_device_s{20e-6, Source::Assumed, "device MPI / NCCL exchange: stream wait, group launch"};
  Param overlap_eff{0.5, Source::Assumed, "fraction of the inner box's compute that hides communication"};
  Param shared_gpu_penalty{0.2, Source::Assumed, "extra compute when ranks share one GPU (context switches)"};
  Param mem_bytes{141e9, Source::DataSheet, "GPU memory (H200 141 GB; H100 80 GB)"};
};

// Measured single-GPU cell rates (cells/s) of the D3Q19 A-A step, by
// sub-domain size; interpolated linearly in log(cells), constant beyond the
// measured range (the kernel is bandwidth-bound from 128^3 up).
struct Rates {
  std::vector<std::pair<double, double>> fp32, fp64;  // (cells, cells/s), any order
  void add(bool fp64, double cells, double rate);
  double rate(bool fp64, double cells) const;  // throws when no point exists
};

// The coupled suspension's costs (PSM step beyond the fluid-only step, per
// cell, at the benchmark's phi and d/l), measured on one GPU.
struct Suspension {
  Param psm_s_per_cell_fp32{0, Source::Measured, "PSM step - fluid step, per cell (phi 0.128, d/l 10)"};
  Param psm_s_per_cell_fp64{0, Source::Measured, ""};
  Param dem_floor_s{70e-6, Source::Measured, "DEM (6 substeps) at 4101 particles: launch-bound"};
  Param dem_particle_steps_per_s{2.2e9, Source::Measured, "DEM particle-steps/s at 10^6-10^7 particles, frictional (dem_h200.json)"};
  Param substeps{6, Source::Measured, "DEM substeps per fluid step"};
  Param diameter{10, Source::Measured, "particle diameter in cells"};
  Param clustering{1.25, Source::Assumed, "densest sub-domain / mean particle load, from clustering"};
  Param particle_speed{0.01, Source::Assumed, "particle speed (cells per step): migration flux"};
  Param refresh_bytes{80, Source::Assumed, "ghost refresh per ghost and DEM substep (position, velocities, id)"};
  Param force_bytes{56, Source::Assumed, "hydrodynamic force + torque returned per ghost, once per step"};
  Param migrate_bytes{256, Source::Assumed, "a migrating particle with its contact history and id"};
  Param rebuild_every{10, Source::Assumed, "fluid steps between neighbour-list builds (migration, host-staged)"};
};

struct Case {
  std::array<long, 3> grid{256, 256, 256};
  bool fp64 = false;
  Transport transport = Transport::HostMpi;
  int ranks = 1;
  int ranks_per_gpu = 1;                  // > 1: ranks sharing one GPU (a communication measurement)
  std::array<int, 3> dims{0, 0, 0};       // {0,0,0}: halo::decompose chooses (fewest halo cells)
  std::array<bool, 3> periodic{true, true, true};
  long particles = 0;                     // 0: fluid only
  double clustering = 0;                  // > 0: overrides Suspension::clustering for this case
};

// The fluid halo of one rank, link by link, as lbm::halo_links builds it:
// the 26 neighbour directions on split axes (a walled end has no link),
// D3Q19 slots with c_a = r_a on every non-zero axis (5 per face, 1 per edge,
// none per corner), cells = one layer along the link's axes times the owned
// extent along the others, bytes in the storage precision.
struct LinkTraffic {
  std::array<int, 3> dir{0, 0, 0};
  int peer = -1;
  long bytes = 0;
  bool same_node = true;
};
std::vector<LinkTraffic> fluid_links(const halo::Decomposition& dec, int rank, int storage_bytes,
                                     int gpus_per_node);
// Neighbours of a rank for particles (corners included: contacts and
// footprints reach them).
int particle_neighbours(const halo::Decomposition& dec, int rank, int& same_node, int gpus_per_node);

struct Prediction {
  std::array<int, 3> dims{1, 1, 1};
  double t_step = 0;      // slowest rank
  double t_compute = 0;   // its compute (incl. split cost, PSM, DEM)
  double t_comm = 0;      // its whole fluid exchange, if nothing were hidden
  double t_exposed = 0;   // fluid exchange not hidden
  double t_latency = 0;   // part of t_exposed that is per-message latency and fixed cost
  double t_particles = 0; // particle messages (exposed) + PSM/DEM imbalance excess
  double t_imbalance = 0; // part of t_particles: PSM + DEM beyond a balanced load
  long halo_bytes = 0;    // fluid bytes sent per step by the slowest rank
  int messages = 0;       // fluid messages per step of that rank
  double mem_per_gpu = 0; // bytes
  bool fits = true;
  double mlups = 0;
};

struct Model {
  Machine machine;
  Rates rates;
  Suspension suspension;
  Prediction predict(const Case& c) const;
  // Bytes a rank's GPU holds: A-A populations (one array), flags, halo
  // buffers, and for the suspension the PSM fields.
  double memory_bytes(const Grid& piece, bool fp64, bool coupled) const;
};

// One measured point from lbdem_bench_scaling (a line of scaling.jsonl).
struct Measured {
  std::string device, transport, mode;
  int ranks = 1, ranks_per_gpu = 1;
  std::array<int, 3> dims{1, 1, 1};
  std::array<long, 3> grid{1, 1, 1};
  bool fp64 = false;
  double t_step = 0, t_compute = 0, t_serial = 0, exposed = 0, comm = 0;
  long halo_bytes = 0;
  int messages = 0;
  double copy_GBs = 0;
};
Case case_of(const Measured& m);

// Fits the model's free constants on measured points: the shared-GPU
// penalty (compute of ranks sharing a GPU), the host-staged exchange's fixed
// cost and host MPI bandwidth (linear least squares on the serial
// communication time), and the overlap efficiency (the value that minimises
// the squared relative error of the step time). One-rank points go into the
// rates. Returns a line per fitted constant.
std::vector<std::string> calibrate(Model& m, const std::vector<Measured>& pts);

}  // namespace lbdem::scaling_model
