#include "halo/device.hpp"

#include <string>

#include "core/error.hpp"

namespace lbdem::halo {

int select_device([[maybe_unused]] const Comm& comm, [[maybe_unused]] TransportKind requested) {
#if defined(LBDEM_HAVE_CUDA)
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess || n <= 0) {
    (void)cudaGetLastError();  // no usable GPU: the host backend runs
    return -1;
  }
  if (requested == TransportKind::Nccl && comm.local_size() > n)
    throw ResourceError("parallel.transport: 'nccl' needs one GPU per rank, but " +
                        std::to_string(comm.local_size()) + " ranks run on this node and it has " +
                        std::to_string(n) + " GPU" + (n == 1 ? "" : "s") + "; start at most " + std::to_string(n) +
                        " ranks per node, or use host_mpi");
  const int device = comm.local_rank() % n;
  LBDEM_CUDA_CHECK(cudaSetDevice(device));
  return device;
#else
  return -1;
#endif
}

}  // namespace lbdem::halo
