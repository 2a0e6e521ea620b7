// HDF5 + XDMF output, CSV time series, output-folder policy (core/output.hpp).
//
// HDF5 C API (serial 1.10+). Every HDF5 call is checked; a failure throws
// lbdem::Error naming the file (and dataset) it concerns. Handles are owned by
// a small RAII wrapper so an exception never leaks an open file.
//
// XDMF: one temporal collection per writer, rewritten after every output step
// through a temporary file and a rename, so a reader (ParaView opening the run
// while it goes) never sees a half-written index.
#include "core/output.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <system_error>
#include <unistd.h>

#include "core/error.hpp"

namespace lbdem::io {

namespace fs = std::filesystem;

namespace {

// Owns one HDF5 identifier; `close` is the matching H5?close function.
class H5Id {
 public:
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Id() {
    if (id_ >= 0) close_(id_);
  }
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

[[noreturn]] void h5_fail(const std::string& path, const std::string& what) {
  throw Error("HDF5: " + what + " failed for '" + path + "'");
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

// Writes a float64 dataset of the given shape, with an optional `units` string attribute.
void write_dataset(hid_t file, const std::string& path, const std::string& name, const std::vector<hsize_t>& dims,
                   const double* data, const std::string& units) {
  hsize_t total = 1;
  for (hsize_t d : dims) total *= d;
  if (total > 0 && data == nullptr) throw Error("output field '" + name + "' for '" + path + "' has no data");
  H5Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  if (!space.ok()) h5_fail(path, "H5Screate_simple for '" + name + "'");
  H5Id dset(H5Dcreate2(file, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  if (!dset.ok()) h5_fail(path, "H5Dcreate2 of dataset '" + name + "'");
  if (total > 0)
    h5_check(H5Dwrite(dset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), path,
             "H5Dwrite of dataset '" + name + "'");
  if (!units.empty()) {
    H5Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    if (!type.ok()) h5_fail(path, "H5Tcopy");
    h5_check(H5Tset_size(type.get(), units.size()), path, "H5Tset_size");
    h5_check(H5Tset_strpad(type.get(), H5T_STR_NULLTERM), path, "H5Tset_strpad");
    H5Id aspace(H5Screate(H5S_SCALAR), H5Sclose);
    if (!aspace.ok()) h5_fail(path, "H5Screate");
    H5Id attr(H5Acreate2(dset.get(), "units", type.get(), aspace.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.ok()) h5_fail(path, "H5Acreate2 'units' on '" + name + "'");
    h5_check(H5Awrite(attr.get(), type.get(), units.c_str()), path, "H5Awrite 'units' on '" + name + "'");
  }
}

void write_scalar_attr(hid_t obj, const std::string& path, const char* name, double value) {
  H5Id space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!space.ok()) h5_fail(path, "H5Screate");
  H5Id attr(H5Acreate2(obj, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) h5_fail(path, std::string("H5Acreate2 '") + name + "'");
  h5_check(H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value), path, std::string("H5Awrite '") + name + "'");
}

// Writes `text` to `path` atomically: temporary file in the same folder, then rename.
void write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp" + std::to_string(static_cast<long>(::getpid()));
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw Error("cannot write '" + tmp + "' (is the output folder writable?)");
    out << text;
    out.flush();
    if (!out) throw Error("writing '" + tmp + "' failed (disk full?)");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error("cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
  }
}

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


}  // namespace

// ---------------------------------------------------------------------------
// GridWriter
// ---------------------------------------------------------------------------
GridWriter::GridWriter(std::string dir, std::string prefix, std::array<long, 3> dims, std::array<double, 3> origin,
                       std::array<double, 3> spacing)
    : dir_(std::move(dir)), prefix_(std::move(prefix)), dims_(dims), origin_(origin), spacing_(spacing) {
  for (int a = 0; a < 3; ++a) {
    if (dims_[a] < 1)
      throw ConfigError("GridWriter: dims[" + std::to_string(a) + "] = " + std::to_string(dims_[a]) +
                        " must be >= 1 (2D grids use nz = 1)");
    if (!(spacing_[a] > 0))
      throw ConfigError("GridWriter: spacing[" + std::to_string(a) + "] = " + num(spacing_[a]) + " must be > 0");
  }
  if (prefix_.empty()) throw ConfigError("GridWriter: empty file prefix");
}

std::string GridWriter::write(long step, double time, const std::vector<GridField>& fields) {
  const std::string file = prefix_ + "_" + step_tag(step) + ".h5";
  const std::string path = (fs::path(dir_) / file).string();
  std::set<std::string> seen;
  for (const auto& f : fields) {
    check_name(f.name, path);
    if (!seen.insert(f.name).second) throw Error("output field '" + f.name + "' given twice for '" + path + "'");
    if (f.components < 1)
      throw Error("output field '" + f.name + "' has components = " + std::to_string(f.components) + " (must be >= 1)");
  }
  {
    H5Id h5(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!h5.ok()) h5_fail(path, "H5Fcreate (is the folder writable?)");
    write_scalar_attr(h5.get(), path, "time", time);
    write_scalar_attr(h5.get(), path, "step", static_cast<double>(step));
    for (const auto& f : fields) {
      std::vector<hsize_t> shape{static_cast<hsize_t>(dims_[2]), static_cast<hsize_t>(dims_[1]),
                                 static_cast<hsize_t>(dims_[0])};
      if (f.components > 1) shape.push_back(static_cast<hsize_t>(f.components));
      write_dataset(h5.get(), path, f.name, shape, f.data, f.units);
    }
    h5_check(H5Fflush(h5.get(), H5F_SCOPE_LOCAL), path, "H5Fflush");
  }
  Entry e{step, time, file, {}};
  for (const auto& f : fields) e.fields.emplace_back(f.name, f.components);
  // Re-writing a step (restart) replaces its entry instead of duplicating it.
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.step == step; });
  if (it != entries_.end()) {
    *it = e;
  } else {
    entries_.push_back(e);
    files_.push_back(path);
  }
  write_xdmf();
  return path;
}

void GridWriter::write_xdmf() const {
  // XDMF orders structured dimensions slowest first (z y x). Cell data on a
  // CoRectMesh needs node dimensions = cells + 1 and Center="Cell".
  const std::string node_dims =
      std::to_string(dims_[2] + 1) + " " + std::to_string(dims_[1] + 1) + " " + std::to_string(dims_[0] + 1);
  const std::string cell_dims = std::to_string(dims_[2]) + " " + std::to_string(dims_[1]) + " " + std::to_string(dims_[0]);
  std::ostringstream x;
  x << xdmf_head(prefix_);
  for (const auto& e : entries_) {
    x << "   <Grid Name=\"" << prefix_ << "_" << step_tag(e.step) << "\" GridType=\"Uniform\">\n";
    x << "    <Time Value=\"" << num(e.time) << "\"/>\n";
    x << "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << node_dims << "\"/>\n";
    x << "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n";
    x << "     <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << num(origin_[2]) << " "
      << num(origin_[1]) << " " << num(origin_[0]) << "</DataItem>\n";
    x << "     <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << num(spacing_[2])
      << " " << num(spacing_[1]) << " " << num(spacing_[0]) << "</DataItem>\n";
    x << "    </Geometry>\n";
    for (const auto& [name, comps] : e.fields) {
      x << "    <Attribute Name=\"" << name << "\" AttributeType=\"" << attribute_type(comps)
        << "\" Center=\"Cell\">\n";
      x << "     <DataItem Dimensions=\"" << cell_dims;
      if (comps > 1) x << ' ' << comps;
      x << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << e.file << ":/" << name << "</DataItem>\n";
      x << "    </Attribute>\n";
    }
    x << "   </Grid>\n";
  }
  x << xdmf_tail();
  write_atomically((fs::path(dir_) / (prefix_ + ".xdmf")).string(), x.str());
}

// ---------------------------------------------------------------------------
// ParticleWriter
// ---------------------------------------------------------------------------
ParticleWriter::ParticleWriter(std::string dir, std::string prefix) : dir_(std::move(dir)), prefix_(std::move(prefix)) {
  if (prefix_.empty()) throw ConfigError("ParticleWriter: empty file prefix");
}

std::string ParticleWriter::write(long step, double time, long n, const double* positions,
                                  const std::vector<ParticleField>& fields) {
  const std::string file = prefix_ + "_" + step_tag(step) + ".h5";
  const std::string path = (fs::path(dir_) / file).string();
  if (n < 0) throw Error("ParticleWriter: particle count " + std::to_string(n) + " for '" + path + "' is negative");
  std::set<std::string> seen{"positions"};
  for (const auto& f : fields) {
    check_name(f.name, path);
    if (!seen.insert(f.name).second)
      throw Error("particle field '" + f.name + "' given twice (or named 'positions') for '" + path + "'");
    if (f.components < 1)
      throw Error("particle field '" + f.name + "' has components = " + std::to_string(f.components) +
                  " (must be >= 1)");
  }
  {
    H5Id h5(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!h5.ok()) h5_fail(path, "H5Fcreate (is the folder writable?)");
    write_scalar_attr(h5.get(), path, "time", time);
    write_scalar_attr(h5.get(), path, "step", static_cast<double>(step));
    const auto nn = static_cast<hsize_t>(n);
    write_dataset(h5.get(), path, "positions", {nn, 3}, positions, "");
    for (const auto& f : fields) {
      std::vector<hsize_t> shape{nn};
      if (f.components > 1) shape.push_back(static_cast<hsize_t>(f.components));
      write_dataset(h5.get(), path, f.name, shape, f.data, "");
    }
    h5_check(H5Fflush(h5.get(), H5F_SCOPE_LOCAL), path, "H5Fflush");
  }
  Entry e{step, time, n, file, {}};
  for (const auto& f : fields) e.fields.emplace_back(f.name, f.components);
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.step == step; });
  if (it != entries_.end())
    *it = e;
  else
    entries_.push_back(e);
  write_xdmf();
  return path;
}

void ParticleWriter::write_xdmf() const {
  std::ostringstream x;
  x << xdmf_head(prefix_);
  for (const auto& e : entries_) {
    const std::string n = std::to_string(e.n);
    x << "   <Grid Name=\"" << prefix_ << "_" << step_tag(e.step) << "\" GridType=\"Uniform\">\n";
    x << "    <Time Value=\"" << num(e.time) << "\"/>\n";
    x << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\"/>\n";
    x << "    <Geometry GeometryType=\"XYZ\">\n";
    x << "     <DataItem Dimensions=\"" << n << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << e.file
      << ":/positions</DataItem>\n";
    x << "    </Geometry>\n";
    for (const auto& [name, comps] : e.fields) {
      x << "    <Attribute Name=\"" << name << "\" AttributeType=\"" << attribute_type(comps)
        << "\" Center=\"Node\">\n";
      x << "     <DataItem Dimensions=\"" << n;
      if (comps > 1) x << ' ' << comps;
      x << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << e.file << ":/" << name << "</DataItem>\n";
      x << "    </Attribute>\n";
    }
    x << "   </Grid>\n";
  }
  x << xdmf_tail();
  write_atomically((fs::path(dir_) / (prefix_ + ".xdmf")).string(), x.str());
}

// ---------------------------------------------------------------------------
// TimeSeries
// ---------------------------------------------------------------------------
TimeSeries::TimeSeries(const std::string& path, std::vector<std::string> columns) : ncols_(columns.size()) {
  if (columns.empty()) throw Error("TimeSeries '" + path + "': no columns given");
  out_.open(path, std::ios::trunc);
  if (!out_) throw Error("cannot open time series '" + path + "' for writing");
  out_.precision(std::numeric_limits<double>::max_digits10);
  for (std::size_t i = 0; i < columns.size(); ++i) out_ << (i ? "," : "") << columns[i];
  out_ << '\n';
  out_.flush();
  if (!out_) throw Error("writing the header of time series '" + path + "' failed");
}

void TimeSeries::append(const std::vector<double>& values) {
  if (!out_.is_open()) throw Error("TimeSeries::append on a series that was never opened");
  if (values.size() != ncols_)
    throw Error("TimeSeries::append: got " + std::to_string(values.size()) + " values for " + std::to_string(ncols_) +
                " columns");
  for (std::size_t i = 0; i < values.size(); ++i) out_ << (i ? "," : "") << values[i];
  out_ << '\n';
  out_.flush();
  if (!out_) throw Error("writing a time-series row failed (disk full?)");
}

// ---------------------------------------------------------------------------
// read_dataset
// ---------------------------------------------------------------------------
std::vector<double> read_dataset(const std::string& h5_path, const std::string& name) {
  std::error_code ec;
  if (!fs::is_regular_file(h5_path, ec)) throw Error("HDF5 file '" + h5_path + "' does not exist");
  H5Id h5(H5Fopen(h5_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!h5.ok()) h5_fail(h5_path, "H5Fopen");
  htri_t exists = H5Lexists(h5.get(), name.c_str(), H5P_DEFAULT);
  if (exists < 0) h5_fail(h5_path, "H5Lexists '" + name + "'");
  if (exists == 0) throw Error("HDF5 file '" + h5_path + "' has no dataset '" + name + "'");
  H5Id dset(H5Dopen2(h5.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!dset.ok()) h5_fail(h5_path, "H5Dopen2 '" + name + "'");
  H5Id space(H5Dget_space(dset.get()), H5Sclose);
  if (!space.ok()) h5_fail(h5_path, "H5Dget_space '" + name + "'");
  const hssize_t npts = H5Sget_simple_extent_npoints(space.get());
  if (npts < 0) h5_fail(h5_path, "H5Sget_simple_extent_npoints '" + name + "'");
  std::vector<double> v(static_cast<std::size_t>(npts));
  if (npts > 0)
    h5_check(H5Dread(dset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), h5_path,
             "H5Dread '" + name + "'");
  return v;
}

// ---------------------------------------------------------------------------
// prepare_output_dir
// ---------------------------------------------------------------------------
void prepare_output_dir(const std::string& dir, bool overwrite) {
  if (dir.empty()) throw ConfigError("output folder is empty: give a folder name");
  std::error_code ec;
  const fs::path p(dir);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw ConfigError("output folder '" + dir + "' exists and is not a folder; choose another output folder");
  fs::create_directories(p, ec);
  if (ec || !fs::is_directory(p))
    throw ConfigError("cannot create output folder '" + dir + "': " + (ec ? ec.message() : "not a folder") +
                      "; choose a writable output folder");

  std::vector<fs::path> entries;
  for (fs::directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec)) entries.push_back(it->path());
  if (ec) throw ConfigError("cannot list output folder '" + dir + "': " + ec.message());
  if (!entries.empty() && !overwrite)
    throw ConfigError("output folder '" + dir + "' is not empty (" + std::to_string(entries.size()) +
                      " entries); pass --overwrite to replace its results, or choose another folder");

  // Writability: create and remove a probe file (permission bits lie for root
  // and on some network file systems; trying is the only reliable test).
  const fs::path probe = p / (".lbdem_write_probe_" + std::to_string(static_cast<long>(::getpid())));
  {
    std::ofstream out(probe);
    bool ok = static_cast<bool>(out);
    if (ok) {
      out << "probe\n";
      out.flush();
      ok = static_cast<bool>(out);
    }
    if (!ok) {
      out.close();
      fs::remove(probe, ec);
      throw ConfigError("output folder '" + dir + "' is not writable; choose a writable output folder");
    }
  }
  fs::remove(probe, ec);
  if (ec) throw ConfigError("cannot remove probe file in output folder '" + dir + "': " + ec.message());

  if (overwrite) {
    static const std::set<std::string> ours{".h5", ".xdmf", ".csv", ".json", ".log"};
    for (const auto& e : entries) {
      if (!fs::is_regular_file(e, ec)) continue;
      if (!ours.count(e.extension().string())) continue;
      fs::remove(e, ec);
      if (ec) throw ConfigError("cannot remove '" + e.string() + "' in output folder '" + dir + "': " + ec.message());
    }
  }
}

}  // namespace lbdem::io
