#pragma once
// The `parallel` section of a case file: how a run is cut over its ranks and
// which transport carries the halos. Read once here for every scene.
#include <array>

#include "core/config.hpp"
#include "halo/transport.hpp"

namespace lbdem::halo {

// parallel:
//   decomposition: [2, 1, 2]   # ranks per axis (their product = the rank count); default: chosen
//   transport: auto            # auto | host_mpi | device_mpi | nccl
struct ParallelOptions {
  std::array<int, 3> decomposition{0, 0, 0};
  TransportKind transport = TransportKind::Auto;
};
ParallelOptions parse_parallel(const Config& root);

}  // namespace lbdem::halo
