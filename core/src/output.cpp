// HDF5 + XDMF output, CSV time series, output-folder policy (core/output.hpp).
//
// HDF5 C API (serial 1.10+). Every HDF5 call is checked; a failure throws one
// line naming the file (and dataset) and the system error HDF5 saw. HDF5's own
// error printing is switched off. Handles are owned by a small RAII wrapper so
// an exception never leaks an open file.
//
// Each .h5 is written under a temporary name in the same folder, closed (which
// flushes it), then renamed: the final name only ever holds a complete file.
// XDMF: one temporal collection per writer, rewritten after every output step
// the same way, so a reader (ParaView opening the run while it goes) never sees
// a half-written index.
#include "core/output.hpp"

#include <fcntl.h>
#include <sys/statvfs.h>
#ifdef __linux__
#include <sys/vfs.h>
#endif
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <system_error>

#include "core/error.hpp"
#include "hdf5_util.hpp"

namespace lbdem::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Creates a dataset of the given shape, float64 (or float32: HDF5 converts the
// doubles handed to H5Dwrite), with an optional `units` string attribute.
H5Id create_dataset(hid_t file, const std::string& path, const std::string& name, const std::vector<hsize_t>& dims,
                    bool fp32, const std::string& units) {
  H5Id space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  if (!space.ok()) h5_fail(path, "H5Screate_simple for '" + name + "'");
  H5Id dset(H5Dcreate2(file, name.c_str(), fp32 ? H5T_IEEE_F32LE : H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                       H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  if (!dset.ok()) h5_fail(path, "H5Dcreate2 of dataset '" + name + "'");
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
  return dset;
}

// Writes a whole dataset of the given shape (float64, or float32 converted from the doubles).
void write_dataset(hid_t file, const std::string& path, const std::string& name, const std::vector<hsize_t>& dims,
                   const double* data, const std::string& units, bool fp32 = false) {
  hsize_t total = 1;
  for (hsize_t d : dims) total *= d;
  if (total > 0 && data == nullptr) throw Error("output field '" + name + "' for '" + path + "' has no data");
  H5Id dset = create_dataset(file, path, name, dims, fp32, units);
  if (total > 0)
    h5_check(H5Dwrite(dset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), path,
             "H5Dwrite of dataset '" + name + "'");
}

// Writes the cells of `box` (cells z y x of the dataset, x fastest, then the
// components) from `data` into an open dataset of shape (nz, ny, nx[, comps]).
void write_box(hid_t dset, const std::string& path, const std::string& name, const CellBox& box, int comps,
               const double* data) {
  H5Id fspace(H5Dget_space(dset), H5Sclose);
  if (!fspace.ok()) h5_fail(path, "H5Dget_space of '" + name + "'");
  const hsize_t start[4] = {static_cast<hsize_t>(box.lo[2]), static_cast<hsize_t>(box.lo[1]),
                            static_cast<hsize_t>(box.lo[0]), 0};
  const hsize_t count[4] = {static_cast<hsize_t>(box.ext[2]), static_cast<hsize_t>(box.ext[1]),
                            static_cast<hsize_t>(box.ext[0]), static_cast<hsize_t>(comps)};
  h5_check(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr), path,
           "H5Sselect_hyperslab of '" + name + "'");
  const hsize_t m = static_cast<hsize_t>(box.size()) * static_cast<hsize_t>(comps);
  H5Id mspace(H5Screate_simple(1, &m, nullptr), H5Sclose);
  if (!mspace.ok()) h5_fail(path, "H5Screate_simple for '" + name + "'");
  h5_check(H5Dwrite(dset, H5T_NATIVE_DOUBLE, mspace.get(), fspace.get(), H5P_DEFAULT, data), path,
           "H5Dwrite of a slab of dataset '" + name + "'");
}

// The Polyvertex connectivity of n points: 0, 1, ..., n-1 as 64-bit integers.
void write_connectivity(hid_t file, const std::string& path, hsize_t n) {
  std::vector<std::int64_t> ids(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<std::int64_t>(i);
  H5Id space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  if (!space.ok()) h5_fail(path, "H5Screate_simple for 'connectivity'");
  H5Id dset(H5Dcreate2(file, "connectivity", H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  if (!dset.ok()) h5_fail(path, "H5Dcreate2 of dataset 'connectivity'");
  if (n > 0)
    h5_check(H5Dwrite(dset.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, ids.data()), path,
             "H5Dwrite of dataset 'connectivity'");
}

void write_scalar_attr(hid_t obj, const std::string& path, const char* name, double value) {
  H5Id space(H5Screate(H5S_SCALAR), H5Sclose);
  if (!space.ok()) h5_fail(path, "H5Screate");
  H5Id attr(H5Acreate2(obj, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) h5_fail(path, std::string("H5Acreate2 '") + name + "'");
  h5_check(H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value), path, std::string("H5Awrite '") + name + "'");
}

// A write to `path` failed with errno `err`: one line, ResourceError when the disk or quota is full.
[[noreturn]] void io_fail(const std::string& path, const std::string& what, int err) {
  std::string msg = "cannot write '" + path + "': " + what;
  if (err != 0) msg += ": " + std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
  if (err == ENOSPC || err == EDQUOT) throw ResourceError(msg + "; free disk space or choose another output folder");
  throw Error(msg);
}

// Renames a complete temporary to its final name (same folder: atomic); on failure removes it.
void rename_into_place(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    const int err = ec.value();
    fs::remove(tmp, ec);
    io_fail(path, "renaming the complete temporary into place", err);
  }
}

// A plain file name (no folder part, not "." or ".."): the only names a manifest may list.
bool plain_name(const std::string& n) {
  return !n.empty() && n != "." && n != ".." && n.find('/') == std::string::npos && n.find('\0') == std::string::npos;
}

// Appends `name` to the manifest of `dir` before the file is created, so that
// even a run killed while writing it has it on record. O_NOFOLLOW: a symlink
// in place of the manifest is refused rather than written through.
void record_in_manifest(const fs::path& dir, const std::string& name) {
  const fs::path m = dir / kManifestName;
  const int fd = ::open(m.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int err = errno;
    io_fail((dir / name).string(), "cannot record it in the run manifest '" + m.string() + "'", err);
  }
  const std::string line = name + "\n";
  const ssize_t w = ::write(fd, line.data(), line.size());
  const int err = errno;
  ::close(fd);
  if (w != static_cast<ssize_t>(line.size()))
    io_fail((dir / name).string(), "cannot record it in the run manifest '" + m.string() + "'", w < 0 ? err : ENOSPC);
}

// Writes `text` to `path` atomically: temporary file in the same folder, then rename.
void write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = temp_name(path);
  errno = 0;
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) io_fail(path, "cannot create the temporary '" + tmp + "'", errno);
    out << text;
    out.flush();
    if (!out) {
      const int err = errno;
      out.close();
      std::error_code ec;
      fs::remove(tmp, ec);
      io_fail(path, "writing the temporary '" + tmp + "' failed", err);
    }
    out.close();
    if (!out) {
      const int err = errno;
      std::error_code ec;
      fs::remove(tmp, ec);
      io_fail(path, "closing the temporary '" + tmp + "' failed", err);
    }
  }
  rename_into_place(tmp, path);
}

// Creates the HDF5 file `path` under its temporary name: `fill` writes into the
// open file, which is then closed (HDF5 writes its caches there, so a full disk
// often shows only now) and renamed. Any failure removes the temporary.
template <class Fill>
void write_h5_atomically(const std::string& path, Fill&& fill) {
  silence_hdf5_errors();
  const std::string tmp = temp_name(path);
  errno = 0;
  try {
    H5Id h5(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!h5.ok()) h5_fail(path, "H5Fcreate (is the folder writable?)");
    fill(h5.get());
    h5_check(H5Fflush(h5.get(), H5F_SCOPE_LOCAL), path, "H5Fflush");
    h5_check(h5.close(), path, "H5Fclose");
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  rename_into_place(tmp, path);
}

// One <Attribute> of a grid: `dims` the data's leading dimensions (cells z y x,
// or the particle count), a trailing component count for non-scalars.
void xdmf_attribute(std::ostream& x, const std::string& name, int comps, const char* center, const std::string& dims,
                    const std::string& file, int bytes = 8) {
  x << "    <Attribute Name=\"" << name << "\" AttributeType=\"" << attribute_type(comps) << "\" Center=\"" << center
    << "\">\n";
  x << "     <DataItem Dimensions=\"" << dims;
  if (comps > 1) x << ' ' << comps;
  x << "\" NumberType=\"Float\" Precision=\"" << bytes << "\" Format=\"HDF\">" << file << ":/" << name << "</DataItem>\n";
  x << "    </Attribute>\n";
}

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

namespace {
const Grid& whole_grid_for_output(const Grid& g) {
  if (!g.whole_grid())
    throw ConfigError("GridWriter: the grid " + g.describe() +
                      " is one rank's piece; field output of a decomposed grid goes through the halo module's writer");
  return g;
}
}  // namespace

GridWriter::GridWriter(std::string dir, std::string prefix, const Grid& grid)
    : GridWriter(std::move(dir), std::move(prefix), whole_grid_for_output(grid).global, grid.origin,
                 {grid.spacing, grid.spacing, grid.spacing}) {}

namespace {
void check_fields(const std::vector<std::pair<std::string, int>>& fields, const std::string& path) {
  std::set<std::string> seen;
  for (const auto& [name, comps] : fields) {
    check_name(name, path);
    if (!seen.insert(name).second) throw Error("output field '" + name + "' given twice for '" + path + "'");
    if (comps < 1) throw Error("output field '" + name + "' has components = " + std::to_string(comps) + " (must be >= 1)");
  }
}
}  // namespace

std::string GridWriter::write(long step, double time, const std::vector<GridField>& fields) {
  std::vector<std::pair<std::string, int>> names;
  for (const auto& f : fields) names.emplace_back(f.name, f.components);
  return write_file(step, time, names, [&](hid_t h5, const std::string& path) {
    for (const auto& f : fields) write_dataset(h5, path, f.name, shape(f.components), f.data, f.units, fp32_);
  });
}

std::string GridWriter::write_slabs(long step, double time, const std::vector<SlabField>& fields, Index slab_cells,
                                    const SlabFill& fill) {
  std::vector<std::pair<std::string, int>> names;
  for (const auto& f : fields) names.emplace_back(f.name, f.components);
  CellBox all;
  for (int a = 0; a < 3; ++a) all.ext[a] = static_cast<int>(dims_[static_cast<std::size_t>(a)]);
  const std::vector<CellBox> slabs = slabs_of(all, slab_cells);
  // Host slab buffers: grown once to the largest request, then reused.
  if (slab_.size() < fields.size()) slab_.resize(fields.size());
  std::vector<double*> out(fields.size());
  for (std::size_t f = 0; f < fields.size(); ++f) {
    const auto need = static_cast<std::size_t>(std::max<Index>(slab_cells, 1)) * static_cast<std::size_t>(std::max(fields[f].components, 1));
    if (slab_[f].size() < need) slab_[f].resize(need);
    out[f] = slab_[f].data();
  }
  return write_file(step, time, names, [&](hid_t h5, const std::string& path) {
    std::vector<H5Id> dsets;
    dsets.reserve(fields.size());
    for (const auto& f : fields) dsets.push_back(create_dataset(h5, path, f.name, shape(f.components), fp32_, f.units));
    for (const CellBox& b : slabs) {
      fill(b, out);
      for (std::size_t f = 0; f < fields.size(); ++f) write_box(dsets[f].get(), path, fields[f].name, b, fields[f].components, out[f]);
    }
  });
}

std::vector<unsigned long long> GridWriter::shape(int components) const {
  std::vector<unsigned long long> s{static_cast<unsigned long long>(dims_[2]), static_cast<unsigned long long>(dims_[1]),
                                    static_cast<unsigned long long>(dims_[0])};
  if (components > 1) s.push_back(static_cast<unsigned long long>(components));
  return s;
}

std::string GridWriter::write_file(long step, double time, const std::vector<std::pair<std::string, int>>& fields,
                                   const std::function<void(std::int64_t, const std::string&)>& body) {
  const std::string file = prefix_ + "_" + step_tag(step) + ".h5";
  const std::string path = (fs::path(dir_) / file).string();
  check_fields(fields, path);
  // Re-writing a step (restart) replaces its entry instead of duplicating it.
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.step == step; });
  if (it == entries_.end()) record_in_manifest(dir_, file);
  std::erase_if(carried_, [&](const auto& c) { return c.first == step; });
  write_h5_atomically(path, [&](hid_t h5) {
    write_scalar_attr(h5, path, "time", time);
    write_scalar_attr(h5, path, "step", static_cast<double>(step));
    body(h5, path);
  });
  Entry e{step, time, file, fields, fp32_ ? 4 : 8};
  if (it != entries_.end()) {
    *it = e;
  } else {
    entries_.push_back(e);
    files_.push_back(path);
  }
  write_xdmf();
  return path;
}

void GridWriter::resume(long up_to_step) {
  carried_ = xdmf_entries((fs::path(dir_) / (prefix_ + ".xdmf")).string(), prefix_, up_to_step);
}

void ParticleWriter::resume(long up_to_step) {
  carried_ = xdmf_entries((fs::path(dir_) / (prefix_ + ".xdmf")).string(), prefix_, up_to_step);
}

void GridWriter::write_xdmf() {
  // XDMF orders structured dimensions slowest first (z y x). Cell data on a
  // CoRectMesh needs node dimensions = cells + 1 and Center="Cell".
  const std::string node_dims =
      std::to_string(dims_[2] + 1) + " " + std::to_string(dims_[1] + 1) + " " + std::to_string(dims_[0] + 1);
  const std::string cell_dims = std::to_string(dims_[2]) + " " + std::to_string(dims_[1]) + " " + std::to_string(dims_[0]);
  std::ostringstream x;
  x << xdmf_head(prefix_);
  for (const auto& c : carried_) x << c.second;
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
    for (const auto& [name, comps] : e.fields) xdmf_attribute(x, name, comps, "Cell", cell_dims, e.file, e.bytes);
    x << "   </Grid>\n";
  }
  x << xdmf_tail();
  if (!xdmf_recorded_) record_in_manifest(dir_, prefix_ + ".xdmf");
  xdmf_recorded_ = true;
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
  std::set<std::string> seen{"positions", "connectivity"};
  for (const auto& f : fields) {
    check_name(f.name, path);
    if (!seen.insert(f.name).second)
      throw Error("particle field '" + f.name + "' given twice (or named 'positions' or 'connectivity') for '" + path +
                  "'");
    if (f.components < 1)
      throw Error("particle field '" + f.name + "' has components = " + std::to_string(f.components) +
                  " (must be >= 1)");
  }
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.step == step; });
  if (it == entries_.end()) record_in_manifest(dir_, file);
  std::erase_if(carried_, [&](const auto& c) { return c.first == step; });
  write_h5_atomically(path, [&](hid_t h5) {
    write_scalar_attr(h5, path, "time", time);
    write_scalar_attr(h5, path, "step", static_cast<double>(step));
    const auto nn = static_cast<hsize_t>(n);
    write_dataset(h5, path, "positions", {nn, 3}, positions, "");
    write_connectivity(h5, path, nn);
    for (const auto& f : fields) {
      std::vector<hsize_t> shape{nn};
      if (f.components > 1) shape.push_back(static_cast<hsize_t>(f.components));
      write_dataset(h5, path, f.name, shape, f.data, "");
    }
  });
  Entry e{step, time, n, file, {}};
  for (const auto& f : fields) e.fields.emplace_back(f.name, f.components);
  if (it != entries_.end())
    *it = e;
  else
    entries_.push_back(e);
  write_xdmf();
  return path;
}

void ParticleWriter::write_xdmf() {
  std::ostringstream x;
  x << xdmf_head(prefix_);
  for (const auto& c : carried_) x << c.second;
  for (const auto& e : entries_) {
    const std::string n = std::to_string(e.n);
    x << "   <Grid Name=\"" << prefix_ << "_" << step_tag(e.step) << "\" GridType=\"Uniform\">\n";
    x << "    <Time Value=\"" << num(e.time) << "\"/>\n";
    // The point list 0..n-1 as an explicit connectivity: the Xdmf3 readers of
    // ParaView count a topology's cells from its data item (none: 0 cells).
    x << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">\n";
    x << "     <DataItem Dimensions=\"" << n << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << e.file
      << ":/connectivity</DataItem>\n";
    x << "    </Topology>\n";
    x << "    <Geometry GeometryType=\"XYZ\">\n";
    x << "     <DataItem Dimensions=\"" << n << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << e.file
      << ":/positions</DataItem>\n";
    x << "    </Geometry>\n";
    for (const auto& [name, comps] : e.fields) xdmf_attribute(x, name, comps, "Node", n, e.file);
    x << "   </Grid>\n";
  }
  x << xdmf_tail();
  if (!xdmf_recorded_) record_in_manifest(dir_, prefix_ + ".xdmf");
  xdmf_recorded_ = true;
  write_atomically((fs::path(dir_) / (prefix_ + ".xdmf")).string(), x.str());
}

// ---------------------------------------------------------------------------
// TimeSeries
// ---------------------------------------------------------------------------
TimeSeries::TimeSeries(const std::string& path, std::vector<std::string> columns) : path_(path), ncols_(columns.size()) {
  if (columns.empty()) throw Error("TimeSeries '" + path + "': no columns given");
  const fs::path p(path);
  record_in_manifest(p.has_parent_path() ? p.parent_path() : fs::path("."), p.filename().string());
  errno = 0;
  out_.open(path, std::ios::trunc);
  if (!out_) io_fail(path, "cannot open the time series", errno);
  out_.precision(std::numeric_limits<double>::max_digits10);
  for (std::size_t i = 0; i < columns.size(); ++i) out_ << (i ? "," : "") << columns[i];
  out_ << '\n';
  out_.flush();
  if (!out_) io_fail(path, "writing the header of the time series failed", errno);
}

void TimeSeries::append(const std::vector<double>& values) {
  if (!out_.is_open()) throw Error("TimeSeries::append on a series that was never opened");
  if (values.size() != ncols_)
    throw Error("TimeSeries::append: got " + std::to_string(values.size()) + " values for " + std::to_string(ncols_) +
                " columns");
  errno = 0;
  for (std::size_t i = 0; i < values.size(); ++i) out_ << (i ? "," : "") << values[i];
  out_ << '\n';
  out_.flush();
  if (!out_) io_fail(path_, "writing a time-series row failed", errno);
}

// ---------------------------------------------------------------------------
// write_text_atomically, read_manifest
// ---------------------------------------------------------------------------
void write_text_atomically(const std::string& path, const std::string& text) {
  const fs::path p(path);
  record_in_manifest(p.has_parent_path() ? p.parent_path() : fs::path("."), p.filename().string());
  write_atomically(path, text);
}

std::vector<std::string> read_manifest(const std::string& dir) {
  std::vector<std::string> names;
  std::ifstream in(fs::path(dir) / kManifestName);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#' && plain_name(line) && line != kManifestName) names.push_back(line);
  return names;
}

// ---------------------------------------------------------------------------
// read_dataset
// ---------------------------------------------------------------------------
std::vector<double> read_dataset(const std::string& h5_path, const std::string& name) {
  silence_hdf5_errors();
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
namespace {

const std::string kProbePrefix = ".lbdem_write_probe_";  // write probes (prepare_output_dir)

// "<name>.tmp<digits>" with <name> in `ours`, or "<prefix><digits>": a
// temporary of one of our files, or a write probe, left by a killed run.
bool leftover_of(const std::string& n, const std::set<std::string>& ours, const std::string& probe_prefix) {
  auto digits_from = [&](std::size_t k) {
    return k < n.size() && std::all_of(n.begin() + static_cast<std::ptrdiff_t>(k), n.end(),
                                       [](char ch) { return ch >= '0' && ch <= '9'; });
  };
  if (n.rfind(probe_prefix, 0) == 0 && digits_from(probe_prefix.size())) return true;
  const auto t = n.rfind(".tmp");
  return t != std::string::npos && t > 0 && digits_from(t + 4) && ours.count(n.substr(0, t)) > 0;
}

std::string name_list(const std::vector<std::string>& names) {
  std::string s;
  const std::size_t shown = std::min<std::size_t>(names.size(), 10);
  for (std::size_t i = 0; i < shown; ++i) s += (i ? ", '" : "'") + names[i] + "'";
  if (names.size() > shown) s += " and " + std::to_string(names.size() - shown) + " more";
  return s;
}

// A kernel file system (proc, sysfs, cgroup, ...) that holds `p`: its
// entries are not files, and a run's output cannot go there. Empty: none.
std::string pseudo_file_system(const fs::path& p) {
#ifdef __linux__
  struct statfs sf {};
  if (::statfs(p.c_str(), &sf) != 0) return {};
  switch (static_cast<unsigned long>(sf.f_type)) {
    case 0x9fa0UL: return "proc";
    case 0x62656572UL: return "sysfs";
    case 0x27e0ebUL: case 0x63677270UL: return "cgroup";
    case 0x64626720UL: return "debugfs";
    case 0x74726163UL: return "tracefs";
    case 0x73636673UL: return "securityfs";
    case 0x1cd1UL: return "devpts";
    case 0xcafe4a11UL: return "bpf";
    default: return {};
  }
#else
  (void)p;
  return {};
#endif
}

// Why a folder cannot take new entries, judged without writing (empty: it
// can, as far as one can tell without trying; prepare_output_dir then tries).
std::string unwritable_reason(const fs::path& p) {
  if (const std::string k = pseudo_file_system(p); !k.empty()) return "it is on the kernel's " + k + " file system";
  struct statvfs sv {};
  if (::statvfs(p.c_str(), &sv) == 0 && (sv.f_flag & ST_RDONLY)) return "it is on a read-only file system";
  if (::access(p.c_str(), W_OK | X_OK) != 0) return "no permission to write there";
  return {};
}

}  // namespace

std::vector<std::string> check_output_dir(const std::string& dir, bool overwrite) {
  if (dir.empty()) throw ConfigError("output folder is empty: give a folder name");
  std::error_code ec;
  const fs::path p(dir);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw ConfigError("output folder '" + dir + "' exists and is not a folder; choose another output folder");
  if (!fs::exists(p, ec)) {
    // To be created: the nearest folder above it that exists must take it.
    fs::path a = p.parent_path();
    while (!a.empty() && !fs::exists(a, ec) && a.has_relative_path()) a = a.parent_path();
    if (a.empty()) a = ".";
    if (!fs::is_directory(a, ec))
      throw ConfigError("cannot create output folder '" + dir + "': '" + a.string() +
                        "' is not a folder; choose a writable output folder");
    if (const std::string why = unwritable_reason(a); !why.empty())
      throw ConfigError("cannot create output folder '" + dir + "' in '" + a.string() + "': " + why +
                        "; choose a writable output folder");
    return {};
  }
  if (const std::string k = pseudo_file_system(p); !k.empty())
    throw ConfigError("output folder '" + dir + "' is on the kernel's " + k +
                      " file system; choose a writable output folder");

  // The folder's entries, not following symlinks (a symlink is listed, never entered).
  std::vector<std::pair<std::string, fs::file_status>> entries;
  bool have_manifest = false, manifest_ok = false;
  for (fs::directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const fs::file_status st = it->symlink_status(ec);
    if (ec) break;
    if (name == kManifestName) {
      have_manifest = true;
      manifest_ok = fs::is_regular_file(st);
      if (manifest_ok) continue;
    }
    entries.emplace_back(name, st);
  }
  if (ec) throw ConfigError("cannot list output folder '" + dir + "': " + ec.message());
  if (!entries.empty() && !overwrite)
    throw ConfigError("output folder '" + dir + "' is not empty (" + std::to_string(entries.size()) +
                      " entries); pass --overwrite to replace its results, or choose another folder");

  // With --overwrite: our files are the regular files the manifest names (and
  // temporaries of them); anything else stops the run before a file is removed.
  std::vector<std::string> remove, foreign;
  if (!entries.empty()) {
    std::set<std::string> ours;
    if (manifest_ok)
      for (auto& n : read_manifest(dir)) ours.insert(n);
    std::set<std::string> with_manifest = ours;  // the manifest's own temporaries are ours too
    with_manifest.insert(kManifestName);
    for (const auto& [name, st] : entries) {
      const bool mine = fs::is_regular_file(st) && (ours.count(name) > 0 || leftover_of(name, with_manifest, kProbePrefix));
      (mine ? remove : foreign).push_back(name);
    }
    std::sort(foreign.begin(), foreign.end());
    if (!foreign.empty() && !manifest_ok)
      throw ConfigError("output folder '" + dir + "' has " +
                        (have_manifest ? std::string("a run manifest '") + kManifestName + "' that is not a regular file"
                                       : std::string("no run manifest '") + kManifestName + "'") +
                        ", so --overwrite cannot tell lbdem's files from others: " + name_list(foreign) +
                        " (files like these may be results of an older lbdem version); nothing was deleted. Remove "
                        "them yourself or choose another output folder");
    if (!foreign.empty())
      throw ConfigError("output folder '" + dir + "' holds " + std::to_string(foreign.size()) +
                        " entries that no lbdem run wrote there: " + name_list(foreign) +
                        "; --overwrite removes only the files named in '" + kManifestName +
                        "', so nothing was deleted. Move those entries away or choose another output folder");
  }
  if (const std::string why = unwritable_reason(p); !why.empty())
    throw ConfigError("output folder '" + dir + "' is not writable (" + why + "); choose a writable output folder");
  return remove;
}

void prepare_output_dir(const std::string& dir, bool overwrite) {
  const std::vector<std::string> remove = check_output_dir(dir, overwrite);
  std::error_code ec;
  const fs::path p(dir);
  fs::create_directories(p, ec);
  if (ec || !fs::is_directory(p))
    throw ConfigError("cannot create output folder '" + dir + "': " + (ec ? ec.message() : "not a folder") +
                      "; choose a writable output folder");

  // Writability: create and remove a probe file (permission bits lie for root
  // and on some network file systems; trying is the only reliable test).
  const fs::path probe = p / (kProbePrefix + std::to_string(static_cast<long>(::getpid())));
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

  for (const auto& name : remove) {
    fs::remove(p / name, ec);
    if (ec) throw ConfigError("cannot remove '" + (p / name).string() + "' in output folder '" + dir + "': " + ec.message());
  }
  // A fresh manifest: this run records its files as it writes them.
  try {
    write_atomically((p / kManifestName).string(),
                     "# lbdem run manifest: every file lbdem wrote in this folder; --overwrite removes only these\n");
  } catch (const Error& e) {
    throw ConfigError(std::string("output folder '") + dir + "': " + e.what());
  }
}

void record_output_file(const std::string& dir, const std::string& name) {
  if (!plain_name(name)) throw Error("output file name '" + name + "' is not a plain file name");
  record_in_manifest(fs::path(dir), name);
}

void replace_file_atomically(const std::string& path, const std::string& text) { write_atomically(path, text); }

}  // namespace lbdem::io
