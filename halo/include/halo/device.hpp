#pragma once
// The GPU of a rank: picked from the node-local rank, so the ranks of a node
// spread over its GPUs (round-robin when there are more ranks than GPUs).
#include "halo/comm.hpp"
#include "halo/transport.hpp"

namespace lbdem::halo {

// Makes device (local rank mod device count) current (cudaSetDevice) and
// returns it; -1 when the binary has no CUDA backend or no GPU is usable
// (nothing is said: the backend choice reports that). With `requested` ==
// Nccl, more ranks on this node than GPUs is a ResourceError (NCCL cannot put
// two ranks on one GPU). Call it before any other CUDA work of the rank.
int select_device(const Comm& comm, TransportKind requested = TransportKind::Auto);

}  // namespace lbdem::halo
