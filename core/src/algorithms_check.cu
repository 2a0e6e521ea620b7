// Instantiates the core algorithms for the common types once, so a build
// error in a CUB path shows up when core is built rather than downstream.
#include "core/algorithms.hpp"

namespace lbdem {
namespace {
struct Ident {
  const double* p;
  LBDEM_HD double operator()(Index i) const { return p[i]; }
};
}  // namespace
double sum_doubles(const Exec& ex, const double* p, Index n, Scratch& s) {
  return transform_reduce(ex, n, 0.0, SumOp{}, Ident{p}, s);
}
template void exclusive_scan<int>(const Exec&, const int*, int*, Index, Scratch&);
template void exclusive_scan<Index>(const Exec&, const Index*, Index*, Index, Scratch&);
template void sort_pairs<unsigned, int>(const Exec&, const unsigned*, unsigned*, const int*, int*, Index, Scratch&, int, int);
}  // namespace lbdem
