// GoogleTest main for tests run under `mpiexec -n N` (tests/CMakeLists.txt:
// lbdem_mpi_test). Every rank runs every test in the same order; rank 0
// prints the usual report, the other ranks only their failures (prefixed by
// the rank). The exit code is non-zero on every rank when any rank failed.
// Without a launcher the binary runs as one rank.
//
// It also counts C++ heap allocations (operator new), so a test can assert
// that a call allocates nothing (alloc_count.hpp).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "alloc_count.hpp"
#include "halo/comm.hpp"

namespace {
std::atomic<long> g_allocations{0};

void* counted_alloc(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}

// Prints failed assertions and failed tests only, each line with the rank.
class FailurePrinter : public ::testing::EmptyTestEventListener {
 public:
  explicit FailurePrinter(int rank) : rank_(rank) {}
  void OnTestPartResult(const ::testing::TestPartResult& r) override {
    if (!r.failed()) return;
    std::fprintf(stderr, "[rank %d] %s:%d: Failure\n%s\n", rank_, r.file_name() ? r.file_name() : "?",
                 r.line_number(), r.summary());
  }
  void OnTestEnd(const ::testing::TestInfo& info) override {
    if (info.result()->Failed())
      std::fprintf(stderr, "[rank %d] FAILED %s.%s\n", rank_, info.test_suite_name(), info.name());
  }

 private:
  int rank_;
};
}  // namespace

void* operator new(std::size_t n) { return counted_alloc(n); }
void* operator new[](std::size_t n) { return counted_alloc(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace lbdem::test {
long heap_allocations() { return g_allocations.load(std::memory_order_relaxed); }
}  // namespace lbdem::test

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  const auto& comm = lbdem::halo::Comm::world();
  if (!comm.root()) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
    listeners.Append(new FailurePrinter(comm.rank()));
  } else {
    std::printf("halo mpi tests: %s\n", comm.describe().c_str());
  }
  const int rc = RUN_ALL_TESTS();
  return comm.any(rc != 0) ? 1 : 0;
}
