// One GPU per test process when CTest hands out GPUs (ctest
// --resource-spec-file, scripts/gpu_suite.sh): CTest names the GPU of each
// resource group of a test in CTEST_RESOURCE_GROUP_<i>_GPUS ("id:2,slots:1").
// Before main(), and so before the first CUDA call, this makes that GPU the
// only one the process sees (CUDA_VISIBLE_DEVICES): device 0 in the code
// (halo::select_device: local rank % visible GPUs). A test on N ranks
// (mpiexec, tests/CMakeLists.txt) has N groups; rank i takes group i.
// Without those variables (a plain ctest or a test run by hand) nothing
// changes. Children (`lbdem` started by a test) inherit the choice.
#include <cstdlib>
#include <string>

namespace {

int this_rank() {
  for (const char* v : {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", "MV2_COMM_WORLD_RANK", "SLURM_PROCID"})
    if (const char* s = std::getenv(v)) return std::atoi(s);
  return 0;
}

bool pin_ctest_gpu() {
  const char* count = std::getenv("CTEST_RESOURCE_GROUP_COUNT");
  if (count == nullptr || std::atoi(count) <= 0) return false;
  const int group = this_rank() % std::atoi(count);
  const std::string name = "CTEST_RESOURCE_GROUP_" + std::to_string(group) + "_GPUS";
  const char* spec = std::getenv(name.c_str());
  if (spec == nullptr) return false;
  // "id:<id>,slots:<n>" (one entry: a group asks for one GPU).
  const std::string s(spec);
  const auto a = s.find("id:");
  if (a == std::string::npos) return false;
  const auto z = s.find(',', a);
  const std::string id = s.substr(a + 3, z == std::string::npos ? std::string::npos : z - a - 3);
  return ::setenv("CUDA_VISIBLE_DEVICES", id.c_str(), 1) == 0;
}

[[maybe_unused]] const bool pinned = pin_ctest_gpu();

}  // namespace
