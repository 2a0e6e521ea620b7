#pragma once
// Backends the tests run on: always the host; CUDA too where a GPU is usable.
// Use with INSTANTIATE_TEST_SUITE_P(..., ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/exec.hpp"

namespace lbdem::test {

inline std::vector<Backend> backends() {
  std::vector<Backend> b{Backend::Host};
  if (cuda_unavailable_reason().empty()) b.push_back(Backend::Cuda);
  return b;
}
inline bool gpu_available() { return cuda_unavailable_reason().empty(); }
inline std::string backend_name(const ::testing::TestParamInfo<Backend>& info) { return to_string(info.param); }

}  // namespace lbdem::test
