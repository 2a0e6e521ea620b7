#pragma once
// HDF5 and XDMF helpers shared by the whole-file writers (core/src/output.cpp)
// and the per-rank piece writers (core/src/piece_output.cpp). Internal to core:
// not installed, not included from outside core/src.
#include <hdf5.h>

#include <string>
#include <utility>
#include <vector>

namespace lbdem::io::detail {

// Owns one HDF5 identifier; `close` is the matching H5?close function.
class H5Id {
 public:
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Id() {
    if (id_ >= 0) close_(id_);
  }
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  H5Id(H5Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  H5Id& operator=(H5Id&&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }
  // Closes now and returns the status (closing a file writes what HDF5 still caches).
  herr_t close() {
    const herr_t rc = id_ >= 0 ? close_(id_) : 0;
    id_ = -1;
    return rc;
  }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// HDF5 prints its whole error stack (tens of lines) on every failure unless
// told not to; the failure is reported as one line by h5_fail instead.
void silence_hdf5_errors();
// One line: the file, what failed, and the system error (from HDF5's stack, or
// errno, which the writers clear before they start). A full disk or quota is a
// ResourceError (exit code 4), anything else an lbdem::Error.
[[noreturn]] void h5_fail(const std::string& path, const std::string& what);
void h5_check(herr_t rc, const std::string& path, const std::string& what);

std::string step_tag(long step);  // "%08ld", the step in every snapshot file name
std::string num(double v);        // a double with every digit it needs (XDMF times, origins)
// "<path>.tmp<pid>": the temporary a file is written under before its rename.
std::string temp_name(const std::string& path);
// A field name that can stand in an HDF5 path and in XDMF: non-empty, no '/', '"', '<', '&'.
void check_name(const std::string& name, const std::string& file);

// XDMF pieces: the AttributeType of a field of `components` values per item,
// and the head and tail of a temporal collection named `name`.
const char* attribute_type(int components);
std::string xdmf_head(const std::string& name);
const char* xdmf_tail();
// The <Grid> entries of steps <= up_to_step in an .xdmf index these writers wrote
// (one "   <Grid Name=\"<prefix>_<step>\"" block per step), for a restart.
std::vector<std::pair<long, std::string>> xdmf_entries(const std::string& path, const std::string& prefix,
                                                       long up_to_step);

}  // namespace lbdem::io::detail
