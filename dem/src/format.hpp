#pragma once
// Error-message formatting for the DEM sources: "{}" placeholders filled in
// order (fmt's headers do not compile under nvcc in this toolchain, and the
// kernel translation units that build messages must).
#include <cstring>
#include <sstream>
#include <string>

namespace lbdem::dem {

inline void fmtx_rest(std::ostringstream& o, const char* f) { o << f; }
template <class A, class... R>
void fmtx_rest(std::ostringstream& o, const char* f, const A& a, const R&... r) {
  const char* p = std::strstr(f, "{}");
  if (!p) { o << f; return; }
  o.write(f, p - f);
  o << a;
  fmtx_rest(o, p + 2, r...);
}
template <class... A>
std::string fmtx(const char* f, const A&... a) {
  std::ostringstream o;
  o.precision(6);
  fmtx_rest(o, f, a...);
  return o.str();
}

}  // namespace lbdem::dem
