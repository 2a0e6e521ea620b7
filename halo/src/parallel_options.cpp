#include "halo/parallel_options.hpp"

namespace lbdem::halo {

ParallelOptions parse_parallel(const Config& root) {
  ParallelOptions po;
  const auto sec = root.optional_section("parallel");
  if (!sec) return po;
  if (sec->has("decomposition")) {
    const auto d = sec->integers("decomposition", 3, 3, 1, 1 << 20);
    for (int a = 0; a < 3; ++a) po.decomposition[static_cast<std::size_t>(a)] = static_cast<int>(d[static_cast<std::size_t>(a)]);
  }
  if (sec->has("transport"))
    po.transport = parse_transport(sec->choice("transport", {"auto", "host_mpi", "mpi", "device_mpi", "cuda_aware_mpi", "nccl"}),
                                   sec->full_key("transport"));
  sec->finish();
  return po;
}

}  // namespace lbdem::halo
