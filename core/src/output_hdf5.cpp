// HDF5 + XDMF output (core/output.hpp): whole-grid fields and particles, and reading a dataset back.
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
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>
#include <system_error>

#include "core/error.hpp"
#include "core/output.hpp"
#include "hdf5_util.hpp"
#include "output_files.hpp"

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
// compare_datasets
// ---------------------------------------------------------------------------
std::vector<DatasetDiff> compare_datasets(const std::string& a, const std::string& b) {
  silence_hdf5_errors();
  std::error_code ec;
  if (!fs::is_regular_file(a, ec)) throw Error("HDF5 file '" + a + "' does not exist");
  H5Id fa(H5Fopen(a.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!fa.ok()) h5_fail(a, "H5Fopen");
  std::error_code ecb;
  if (!fs::is_regular_file(b, ecb)) throw Error("HDF5 file '" + b + "' does not exist");
  H5Id fb(H5Fopen(b.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!fb.ok()) h5_fail(b, "H5Fopen");
  std::vector<std::string> names;  // the datasets at the root of `a`
  H5G_info_t gi;
  h5_check(H5Gget_info(fa.get(), &gi), a, "H5Gget_info");
  for (hsize_t i = 0; i < gi.nlinks; ++i) {
    char buf[256] = {};
    if (H5Lget_name_by_idx(fa.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, buf, sizeof buf, H5P_DEFAULT) < 0)
      h5_fail(a, "H5Lget_name_by_idx");
    H5Id d(H5Dopen2(fa.get(), buf, H5P_DEFAULT), H5Dclose);  // groups do not open as datasets
    if (d.ok()) names.emplace_back(buf);
  }
  // Dataset by dataset, a band of the slowest axis at a time (at most kBand
  // values of each file in memory): a whole-grid file is never held whole.
  constexpr hsize_t kBand = hsize_t{1} << 22;
  std::vector<DatasetDiff> out;
  std::vector<double> va, vb;
  for (const std::string& n : names) {
    auto open = [&n](hid_t f, const std::string& path, std::vector<hsize_t>& dims) {
      htri_t exists = H5Lexists(f, n.c_str(), H5P_DEFAULT);
      if (exists <= 0) throw Error("HDF5 file '" + path + "' has no dataset '" + n + "'");
      H5Id d(H5Dopen2(f, n.c_str(), H5P_DEFAULT), H5Dclose);
      if (!d.ok()) h5_fail(path, "H5Dopen2 '" + n + "'");
      H5Id sp(H5Dget_space(d.get()), H5Sclose);
      const int rank = H5Sget_simple_extent_ndims(sp.get());
      if (rank < 0) h5_fail(path, "H5Sget_simple_extent_ndims '" + n + "'");
      dims.assign(static_cast<std::size_t>(rank), 0);
      if (rank > 0) H5Sget_simple_extent_dims(sp.get(), dims.data(), nullptr);
      return d;
    };
    std::vector<hsize_t> da, db;
    H5Id sa = open(fa.get(), a, da), sb = open(fb.get(), b, db);
    hsize_t total = 1, row = 1;
    for (std::size_t k = 0; k < da.size(); ++k) {
      total *= da[k];
      if (k > 0) row *= da[k];
    }
    if (da != db) {
      hsize_t tb = 1;
      for (hsize_t x : db) tb *= x;
      throw Error("dataset '" + n + "' holds " + std::to_string(total) + " values in '" + a + "' but " +
                  std::to_string(tb) + " (or another shape) in '" + b + "'");
    }
    DatasetDiff d{n, static_cast<std::size_t>(total)};
    const hsize_t rows = da.empty() ? 1 : da[0];
    const hsize_t band = std::max<hsize_t>(1, kBand / std::max<hsize_t>(row, 1));
    for (hsize_t r0 = 0; r0 < rows && total > 0; r0 += band) {
      const hsize_t m = std::min(band, rows - r0);
      auto read = [&](hid_t dset, const std::string& path, std::vector<double>& v) {
        v.resize(static_cast<std::size_t>(m * row));
        H5Id fsp(H5Dget_space(dset), H5Sclose);
        if (!da.empty()) {
          std::vector<hsize_t> start(da.size(), 0), count = da;
          start[0] = r0;
          count[0] = m;
          h5_check(H5Sselect_hyperslab(fsp.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), path,
                   "H5Sselect_hyperslab '" + n + "'");
        }
        const hsize_t cnt = m * row;
        H5Id msp(H5Screate_simple(1, &cnt, nullptr), H5Sclose);
        h5_check(H5Dread(dset, H5T_NATIVE_DOUBLE, msp.get(), fsp.get(), H5P_DEFAULT, v.data()), path,
                 "H5Dread '" + n + "'");
      };
      read(sa.get(), a, va);
      read(sb.get(), b, vb);
      d.bitwise = d.bitwise && std::memcmp(va.data(), vb.data(), va.size() * sizeof(double)) == 0;
      for (std::size_t i = 0; i < va.size(); ++i) {
        d.max_abs = std::max(d.max_abs, std::abs(va[i] - vb[i]));
        // a NaN on one side only: an infinite difference (std::max would drop it)
        if (std::isnan(va[i]) != std::isnan(vb[i])) d.max_abs = std::numeric_limits<double>::infinity();
        d.scale = std::max(d.scale, std::abs(va[i]));
      }
    }
    out.push_back(d);
  }
  return out;
}

}  // namespace lbdem::io
