#pragma once
// C++ heap allocations (operator new) made by this process so far; counted by
// the MPI test main (mpi_test_main.cpp). The difference around a call is the
// number of allocations it made.
namespace lbdem::test {
long heap_allocations();
}  // namespace lbdem::test
