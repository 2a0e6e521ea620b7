// HDF5 and XDMF helpers shared by the writers of core/ (core/src/hdf5_util.hpp).
#include "hdf5_util.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/error.hpp"

namespace lbdem::io::detail {

void silence_hdf5_errors() {
  static const bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)done;
}

namespace {
// The errno a failed HDF5 call met in the file driver: its error stack holds a
// record "... errno = N, error message = '...'" (sec2 driver). 0 when none.
herr_t find_errno(unsigned, const H5E_error2_t* e, void* data) {
  auto* out = static_cast<int*>(data);
  if (*out == 0 && e != nullptr && e->desc != nullptr) {
    if (const char* p = std::strstr(e->desc, "errno = ")) *out = std::atoi(p + 8);
  }
  return 0;
}
}  // namespace

[[noreturn]] void h5_fail(const std::string& path, const std::string& what) {
  const int saved = errno;
  int err = 0;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, find_errno, &err);
  if (err == 0) err = saved;
  H5Eclear2(H5E_DEFAULT);
  std::string msg = "HDF5: " + what + " failed for '" + path + "'";
  if (err != 0) msg += ": " + std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
  if (err == ENOSPC || err == EDQUOT || err == EFBIG)
    throw ResourceError(msg + "; free disk space or choose another output folder");
  throw Error(msg);
}

void h5_check(herr_t rc, const std::string& path, const std::string& what) {
  if (rc < 0) h5_fail(path, what);
}

std::string step_tag(long step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%08ld", step);
  return buf;
}

std::string num(double v) {
  std::ostringstream os;
  os.precision(std::numeric_limits<double>::max_digits10);
  os << v;
  return os.str();
}

void check_name(const std::string& name, const std::string& file) {
  if (name.empty() || name.find('/') != std::string::npos || name.find('"') != std::string::npos ||
      name.find('<') != std::string::npos || name.find('&') != std::string::npos)
    throw Error("output field name '" + name + "' for '" + file +
                "' is not valid: use a non-empty name without '/', '\"', '<' or '&'");
}

std::string temp_name(const std::string& path) { return path + ".tmp" + std::to_string(static_cast<long>(::getpid())); }

const char* attribute_type(int components) {
  switch (components) {
    case 1: return "Scalar";
    case 3: return "Vector";
    case 6: return "Tensor6";
    case 9: return "Tensor";
    default: return "Matrix";
  }
}

std::string xdmf_head(const std::string& name) {
  return "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
         "  <Grid Name=\"" + name + "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
}
const char* xdmf_tail() { return "  </Grid>\n </Domain>\n</Xdmf>\n"; }

// The <Grid> entries of steps <= up_to_step in an .xdmf index this file wrote
// (one "   <Grid Name=\"<prefix>_<step>\"" block per step), for a restart.
std::vector<std::pair<long, std::string>> xdmf_entries(const std::string& path, const std::string& prefix,
                                                       long up_to_step) {
  std::vector<std::pair<long, std::string>> out;
  std::ifstream in(path);
  const std::string open = "   <Grid Name=\"" + prefix + "_";
  std::string line, block;
  long step = -1;
  while (std::getline(in, line)) {
    if (line.rfind(open, 0) == 0) {
      step = std::atol(line.c_str() + open.size());
      block.clear();
    }
    if (step < 0) continue;
    block += line + "\n";
    if (line == "   </Grid>") {
      if (step <= up_to_step) out.emplace_back(step, block);
      step = -1;
    }
  }
  return out;
}

}  // namespace lbdem::io::detail
