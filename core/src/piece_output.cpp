// Per-rank snapshot pieces, their XDMF index, and the join of a step's pieces
// into one whole file (core/piece_output.hpp). Serial HDF5 C API: each rank
// writes only its own file; no file is ever opened by two processes.
#include "core/piece_output.hpp"

#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "core/memory_use.hpp"
#include "hdf5_util.hpp"

namespace lbdem::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Creates `path` under its temporary name, lets `fill` write into it, closes and renames it.
template <class Fill>
void write_h5(const std::string& path, Fill&& fill) {
  silence_hdf5_errors();
  const std::string tmp = temp_name(path);
  errno = 0;
  try {
    H5Id f(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!f.ok()) h5_fail(path, "H5Fcreate (is the folder writable?)");
    fill(f.get());
    h5_check(H5Fflush(f.get(), H5F_SCOPE_LOCAL), path, "H5Fflush");
    h5_check(f.close(), path, "H5Fclose");
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error("cannot write '" + path + "': renaming the complete temporary into place failed");
  }
}

void put_attr(hid_t obj, const std::string& path, const char* name, const std::vector<double>& v) {
  const hsize_t n = v.size();
  H5Id space(n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr), H5Sclose);
  if (!space.ok()) h5_fail(path, "H5Screate");
  H5Id a(H5Acreate2(obj, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok()) h5_fail(path, std::string("H5Acreate2 '") + name + "'");
  h5_check(H5Awrite(a.get(), H5T_NATIVE_DOUBLE, v.data()), path, std::string("H5Awrite '") + name + "'");
}
// An attribute's values (empty when absent).
std::vector<double> get_attr(hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) return {};
  H5Id a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!a.ok()) return {};
  H5Id sp(H5Aget_space(a.get()), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(sp.get());
  std::vector<double> v(static_cast<std::size_t>(std::max<hssize_t>(n, 0)));
  if (!v.empty() && H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()) < 0) return {};
  return v;
}
void put_units(hid_t dset, const std::string& path, const std::string& units) {
  if (units.empty()) return;
  H5Id type(H5Tcopy(H5T_C_S1), H5Tclose);
  h5_check(H5Tset_size(type.get(), units.size()), path, "H5Tset_size");
  h5_check(H5Tset_strpad(type.get(), H5T_STR_NULLTERM), path, "H5Tset_strpad");
  H5Id sp(H5Screate(H5S_SCALAR), H5Sclose);
  H5Id a(H5Acreate2(dset, "units", type.get(), sp.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok()) h5_fail(path, "H5Acreate2 'units'");
  h5_check(H5Awrite(a.get(), type.get(), units.c_str()), path, "H5Awrite 'units'");
}
std::string get_units(hid_t dset) {
  if (H5Aexists(dset, "units") <= 0) return "";
  H5Id a(H5Aopen(dset, "units", H5P_DEFAULT), H5Aclose);
  H5Id t(H5Aget_type(a.get()), H5Tclose);
  const std::size_t n = H5Tget_size(t.get());
  std::string s(n, '\0');
  if (H5Aread(a.get(), t.get(), s.data()) < 0) return "";
  s.resize(std::strlen(s.c_str()));
  return s;
}

H5Id make_dataset(hid_t file, const std::string& path, const std::string& name, const std::vector<hsize_t>& dims,
                  hid_t type) {
  H5Id sp(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  if (!sp.ok()) h5_fail(path, "H5Screate_simple for '" + name + "'");
  H5Id d(H5Dcreate2(file, name.c_str(), type, sp.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!d.ok()) h5_fail(path, "H5Dcreate2 of dataset '" + name + "'");
  return d;
}

// Writes `count` values of memory type `mtype` at the hyperslab (start, count) of `dset`.
void write_slab(hid_t dset, const std::string& path, const std::string& name, const std::vector<hsize_t>& start,
                const std::vector<hsize_t>& count, hid_t mtype, const void* data) {
  H5Id fs_(H5Dget_space(dset), H5Sclose);
  if (!fs_.ok()) h5_fail(path, "H5Dget_space of '" + name + "'");
  hsize_t m = 1;
  for (hsize_t c : count) m *= c;
  if (m == 0) return;
  h5_check(H5Sselect_hyperslab(fs_.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), path,
        "H5Sselect_hyperslab of '" + name + "'");
  H5Id ms(H5Screate_simple(1, &m, nullptr), H5Sclose);
  h5_check(H5Dwrite(dset, mtype, ms.get(), fs_.get(), H5P_DEFAULT, data), path, "H5Dwrite of '" + name + "'");
}

void write_ids(hid_t file, const std::string& path, hsize_t n) {
  H5Id d = make_dataset(file, path, "connectivity", {n}, H5T_STD_I64LE);
  std::vector<std::int64_t> ids(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<std::int64_t>(i);
  if (n > 0) h5_check(H5Dwrite(d.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, ids.data()), path, "H5Dwrite of 'connectivity'");
}

void xdmf_attr(std::ostream& x, const std::string& ind, const std::string& name, int comps, const char* center,
               const std::string& dims, const std::string& file, int bytes) {
  x << ind << "<Attribute Name=\"" << name << "\" AttributeType=\"" << attribute_type(comps) << "\" Center=\"" << center
    << "\">\n"
    << ind << " <DataItem Dimensions=\"" << dims;
  if (comps > 1) x << ' ' << comps;
  x << "\" NumberType=\"Float\" Precision=\"" << bytes << "\" Format=\"HDF\">" << file << ":/" << name
    << "</DataItem>\n"
    << ind << "</Attribute>\n";
}

// A uniform CoRectMesh grid of `cells` (x y z) at `origin` (x y z, metres).
void xdmf_mesh(std::ostream& x, const std::string& ind, const std::array<long, 3>& cells,
               const std::array<double, 3>& origin, double h) {
  x << ind << "<Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << cells[2] + 1 << " " << cells[1] + 1 << " "
    << cells[0] + 1 << "\"/>\n"
    << ind << "<Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
    << ind << " <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << num(origin[2]) << " "
    << num(origin[1]) << " " << num(origin[0]) << "</DataItem>\n"
    << ind << " <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << num(h) << " "
    << num(h) << " " << num(h) << "</DataItem>\n"
    << ind << "</Geometry>\n";
}

// Rewrites <dir>/<name> with the head, carried blocks, the text of `body` and the tail.
void write_index(const std::string& dir, const std::string& name, const std::string& title, bool& recorded,
                 const std::vector<std::pair<long, std::string>>& carried, const std::string& body) {
  std::ostringstream x;
  x << xdmf_head(title);
  for (const auto& c : carried) x << c.second;
  x << body << xdmf_tail();
  if (!recorded) record_output_file(dir, name);
  recorded = true;
  replace_file_atomically((fs::path(dir) / name).string(), x.str());
}

}  // namespace

std::string piece_file_name(const std::string& prefix, long step, int rank, int ranks) {
  if (ranks <= 1) return prefix + "_" + step_tag(step) + ".h5";
  char b[32];
  std::snprintf(b, sizeof b, "_r%04d", rank);
  return prefix + "_" + step_tag(step) + b + ".h5";
}

// ---------------------------------------------------------------------------
// PieceGridWriter
// ---------------------------------------------------------------------------
PieceGridWriter::PieceGridWriter(std::string dir, std::string prefix, const Grid& whole, std::vector<PieceBox> pieces,
                                 int rank, CellBox owned)
    : dir_(std::move(dir)), prefix_(std::move(prefix)), whole_(whole), pieces_(std::move(pieces)), rank_(rank),
      owned_(owned) {
  if (prefix_.empty()) throw Error("PieceGridWriter: empty file prefix");
  if (rank_ < 0 || rank_ >= static_cast<int>(pieces_.size()))
    throw Error("PieceGridWriter: rank " + std::to_string(rank_) + " of " + std::to_string(pieces_.size()) + " pieces");
  for (int a = 0; a < 3; ++a)
    if (owned_.ext[a] != pieces_[static_cast<std::size_t>(rank_)].cells[static_cast<std::size_t>(a)])
      throw Error("PieceGridWriter: the owned box does not match rank " + std::to_string(rank_) + "'s piece");
}

void PieceGridWriter::record(long step) {
  if (std::any_of(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.step == step; })) return;
  const int R = static_cast<int>(pieces_.size());
  for (int r = 0; r < R; ++r) record_output_file(dir_, piece_file_name(prefix_, step, r, R));
}

std::string PieceGridWriter::write_piece(long step, double time, const std::vector<SlabField>& fields, Index slab_cells,
                                         const SlabFill& fill) {
  const int R = static_cast<int>(pieces_.size());
  const std::string path = (fs::path(dir_) / piece_file_name(prefix_, step, rank_, R)).string();
  std::set<std::string> seen;
  for (const auto& f : fields) {
    check_name(f.name, path);
    if (!seen.insert(f.name).second) throw Error("output field '" + f.name + "' given twice for '" + path + "'");
    if (f.components < 1) throw Error("output field '" + f.name + "' has components < 1");
  }
  const PieceBox& me = pieces_[static_cast<std::size_t>(rank_)];
  const Index cells = std::max<Index>(1, std::min<Index>(slab_cells, owned_.size()));
  if (slab_.size() < fields.size()) slab_.resize(fields.size());
  std::vector<double*> out(fields.size());
  for (std::size_t f = 0; f < fields.size(); ++f) {
    const auto need = static_cast<std::size_t>(cells) * static_cast<std::size_t>(fields[f].components);
    if (slab_[f].size() < need) slab_[f].resize(need);
    largest_ = std::max(largest_, slab_[f].size());
    out[f] = slab_[f].data();
  }
  write_h5(path, [&](hid_t h5) {
    put_attr(h5, path, "time", {time});
    put_attr(h5, path, "step", {double(step)});
    put_attr(h5, path, "piece_offset", {double(me.offset[0]), double(me.offset[1]), double(me.offset[2])});
    put_attr(h5, path, "global_cells", {double(whole_.global[0]), double(whole_.global[1]), double(whole_.global[2])});
    put_attr(h5, path, "origin", {whole_.origin[0], whole_.origin[1], whole_.origin[2]});
    put_attr(h5, path, "spacing", {whole_.spacing});
    put_attr(h5, path, "rank", {double(rank_)});
    put_attr(h5, path, "ranks", {double(R)});
    std::vector<H5Id> ds;
    ds.reserve(fields.size());
    for (const auto& f : fields) {
      std::vector<hsize_t> dims{hsize_t(me.cells[2]), hsize_t(me.cells[1]), hsize_t(me.cells[0])};
      if (f.components > 1) dims.push_back(hsize_t(f.components));
      ds.push_back(make_dataset(h5, path, f.name, dims, fp32_ ? H5T_IEEE_F32LE : H5T_IEEE_F64LE));
      put_units(ds.back().get(), path, f.units);
    }
    for (const CellBox& b : slabs_of(owned_, cells)) {
      for (int a = 0; a < 3; ++a)
        if (b.lo[a] < owned_.lo[a] || b.lo[a] + b.ext[a] > owned_.lo[a] + owned_.ext[a] || b.size() > cells)
          throw Error("PieceGridWriter: a slab beyond rank " + std::to_string(rank_) + "'s piece");
      fill(b, out);
      for (std::size_t f = 0; f < fields.size(); ++f) {
        std::vector<hsize_t> start{hsize_t(b.lo[2] - owned_.lo[2]), hsize_t(b.lo[1] - owned_.lo[1]),
                                   hsize_t(b.lo[0] - owned_.lo[0])};
        std::vector<hsize_t> count{hsize_t(b.ext[2]), hsize_t(b.ext[1]), hsize_t(b.ext[0])};
        if (fields[f].components > 1) {
          start.push_back(0);
          count.push_back(hsize_t(fields[f].components));
        }
        if (fp32_) {  // rounded here (a C cast: HDF5's own double -> float rounding) and written without conversion
          const auto m = static_cast<std::size_t>(b.size()) * static_cast<std::size_t>(fields[f].components);
          if (slab32_.size() < m) slab32_.resize(m);
          std::copy_n(out[f], m, slab32_.data());
          write_slab(ds[f].get(), path, fields[f].name, start, count, H5T_NATIVE_FLOAT, slab32_.data());
        } else {
          write_slab(ds[f].get(), path, fields[f].name, start, count, H5T_NATIVE_DOUBLE, out[f]);
        }
      }
    }
  });
  return path;
}

void PieceGridWriter::index(long step, double time, const std::vector<SlabField>& fields) {
  Entry e{step, time, {}, fp32_ ? 4 : 8};
  for (const auto& f : fields) e.fields.emplace_back(f.name, f.components);
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.step == step; });
  if (it != entries_.end())
    *it = e;
  else
    entries_.push_back(e);
  std::erase_if(carried_, [&](const auto& c) { return c.first == step; });
  const int R = static_cast<int>(pieces_.size());
  std::ostringstream x;
  for (const auto& en : entries_) {
    x << "   <Grid Name=\"" << prefix_ << "_" << step_tag(en.step) << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
      << "    <Time Value=\"" << num(en.time) << "\"/>\n";
    for (int r = 0; r < R; ++r) {
      const PieceBox& p = pieces_[static_cast<std::size_t>(r)];
      const std::string file = piece_file_name(prefix_, en.step, r, R);
      x << "    <Grid Name=\"" << file.substr(0, file.size() - 3) << "\" GridType=\"Uniform\">\n";
      std::array<double, 3> o{};
      for (std::size_t a = 0; a < 3; ++a) o[a] = whole_.origin[a] + double(p.offset[a]) * whole_.spacing;
      xdmf_mesh(x, "     ", p.cells, o, whole_.spacing);
      const std::string dims = std::to_string(p.cells[2]) + " " + std::to_string(p.cells[1]) + " " + std::to_string(p.cells[0]);
      for (const auto& [name, comps] : en.fields) xdmf_attr(x, "     ", name, comps, "Cell", dims, file, en.bytes);
      x << "    </Grid>\n";
    }
    x << "   </Grid>\n";
  }
  write_index(dir_, prefix_ + ".xdmf", prefix_, xdmf_recorded_, carried_, x.str());
}

void PieceGridWriter::resume(long up_to_step) {
  carried_ = xdmf_entries((fs::path(dir_) / (prefix_ + ".xdmf")).string(), prefix_, up_to_step);
}

// ---------------------------------------------------------------------------
// PieceParticleWriter
// ---------------------------------------------------------------------------
PieceParticleWriter::PieceParticleWriter(std::string dir, std::string prefix, int rank, int ranks)
    : dir_(std::move(dir)), prefix_(std::move(prefix)), rank_(rank), ranks_(ranks) {
  if (prefix_.empty()) throw Error("PieceParticleWriter: empty file prefix");
}

void PieceParticleWriter::record(long step) {
  if (std::any_of(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.step == step; })) return;
  for (int r = 0; r < ranks_; ++r) record_output_file(dir_, piece_file_name(prefix_, step, r, ranks_));
}

std::string PieceParticleWriter::write_piece(long step, double time, long n, const double* positions,
                                             const std::vector<ParticleField>& fields) {
  const std::string path = (fs::path(dir_) / piece_file_name(prefix_, step, rank_, ranks_)).string();
  if (n < 0) throw Error("PieceParticleWriter: negative particle count for '" + path + "'");
  std::set<std::string> seen{"positions", "connectivity"};
  for (const auto& f : fields) {
    check_name(f.name, path);
    if (!seen.insert(f.name).second) throw Error("particle field '" + f.name + "' given twice for '" + path + "'");
  }
  write_h5(path, [&](hid_t h5) {
    put_attr(h5, path, "time", {time});
    put_attr(h5, path, "step", {double(step)});
    put_attr(h5, path, "rank", {double(rank_)});
    put_attr(h5, path, "ranks", {double(ranks_)});
    const auto nn = static_cast<hsize_t>(n);
    auto whole = [&](const std::string& name, const std::vector<hsize_t>& dims, const double* d) {
      H5Id ds = make_dataset(h5, path, name, dims, H5T_IEEE_F64LE);
      if (nn > 0) h5_check(H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, d), path, "H5Dwrite of '" + name + "'");
    };
    whole("positions", {nn, 3}, positions);
    write_ids(h5, path, nn);
    for (const auto& f : fields) {
      std::vector<hsize_t> dims{nn};
      if (f.components > 1) dims.push_back(hsize_t(f.components));
      whole(f.name, dims, f.data);
    }
  });
  return path;
}

void PieceParticleWriter::index(long step, double time, const std::vector<long>& counts,
                                const std::vector<std::pair<std::string, int>>& fields) {
  Entry e{step, time, counts, fields};
  auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.step == step; });
  if (it != entries_.end())
    *it = e;
  else
    entries_.push_back(e);
  std::erase_if(carried_, [&](const auto& c) { return c.first == step; });
  std::ostringstream x;
  for (const auto& en : entries_) {
    x << "   <Grid Name=\"" << prefix_ << "_" << step_tag(en.step) << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
      << "    <Time Value=\"" << num(en.time) << "\"/>\n";
    for (int r = 0; r < static_cast<int>(en.counts.size()); ++r) {
      const long n = en.counts[static_cast<std::size_t>(r)];
      if (n <= 0) continue;  // an empty piece: no grid (zero-size data items upset the readers)
      const std::string file = piece_file_name(prefix_, en.step, r, static_cast<int>(en.counts.size()));
      const std::string ns = std::to_string(n);
      x << "    <Grid Name=\"" << file.substr(0, file.size() - 3) << "\" GridType=\"Uniform\">\n"
        << "     <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << ns << "\" NodesPerElement=\"1\">\n"
        << "      <DataItem Dimensions=\"" << ns << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << file
        << ":/connectivity</DataItem>\n"
        << "     </Topology>\n"
        << "     <Geometry GeometryType=\"XYZ\">\n"
        << "      <DataItem Dimensions=\"" << ns << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << file
        << ":/positions</DataItem>\n"
        << "     </Geometry>\n";
      for (const auto& [name, comps] : en.fields) xdmf_attr(x, "     ", name, comps, "Node", ns, file, 8);
      x << "    </Grid>\n";
    }
    x << "   </Grid>\n";
  }
  write_index(dir_, prefix_ + ".xdmf", prefix_, xdmf_recorded_, carried_, x.str());
}

void PieceParticleWriter::resume(long up_to_step) {
  carried_ = xdmf_entries((fs::path(dir_) / (prefix_ + ".xdmf")).string(), prefix_, up_to_step);
}

// ---------------------------------------------------------------------------
// join
// ---------------------------------------------------------------------------
namespace {

// "<prefix>_<8+ digits>" then "" (whole) or "_r<digits>" (a piece), ".h5": the step and rank (-1: whole).
bool parse_name(const std::string& n, const std::string& prefix, long& step, int& rank) {
  const std::string head = prefix + "_";
  if (n.rfind(head, 0) != 0 || n.size() < head.size() + 11 || n.compare(n.size() - 3, 3, ".h5") != 0) return false;
  std::size_t i = head.size(), j = i;
  while (j < n.size() && std::isdigit(static_cast<unsigned char>(n[j]))) ++j;
  if (j - i < 8) return false;
  step = std::atol(n.substr(i, j - i).c_str());
  const std::string rest = n.substr(j, n.size() - 3 - j);
  if (rest.empty()) {
    rank = -1;
    return true;
  }
  if (rest.size() < 3 || rest.compare(0, 2, "_r") != 0 || rest.find_first_not_of("0123456789", 2) != std::string::npos)
    return false;
  rank = std::atoi(rest.c_str() + 2);
  return true;
}

H5Id open_ro(const std::string& path) {
  silence_hdf5_errors();
  H5Id f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.ok()) throw Error("cannot open '" + path + "' (HDF5): is it a complete snapshot piece?");
  return f;
}

// The datasets of an open file, by name (connectivity excluded).
std::vector<std::string> dataset_names(hid_t f) {
  std::vector<std::string> out;
  H5G_info_t info;
  if (H5Gget_info(f, &info) < 0) return out;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char b[256];
    const ssize_t n = H5Lget_name_by_idx(f, ".", H5_INDEX_NAME, H5_ITER_INC, i, b, sizeof b, H5P_DEFAULT);
    if (n > 0 && n < static_cast<ssize_t>(sizeof b) && std::string(b) != "connectivity") out.emplace_back(b);
  }
  return out;
}

struct DsInfo {
  std::vector<hsize_t> dims;
  std::size_t bytes = 8;  // of one stored value
  std::string units;
};
DsInfo info_of(hid_t f, const std::string& name, const std::string& path) {
  H5Id d(H5Dopen2(f, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.ok()) throw Error("'" + path + "' has no dataset '" + name + "' (a piece of another run?)");
  H5Id sp(H5Dget_space(d.get()), H5Sclose);
  DsInfo in;
  in.dims.resize(static_cast<std::size_t>(H5Sget_simple_extent_ndims(sp.get())));
  H5Sget_simple_extent_dims(sp.get(), in.dims.data(), nullptr);
  H5Id t(H5Dget_type(d.get()), H5Tclose);
  in.bytes = H5Tget_size(t.get());
  in.units = get_units(d.get());
  return in;
}
std::vector<double> read_all(hid_t f, const std::string& name, const std::string& path) {
  H5Id d(H5Dopen2(f, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.ok()) throw Error("'" + path + "' has no dataset '" + name + "'");
  H5Id sp(H5Dget_space(d.get()), H5Sclose);
  std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(sp.get())));
  if (!v.empty()) h5_check(H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path, "H5Dread of '" + name + "'");
  return v;
}

// Rewrites <prefix>_joined.xdmf over every whole file of `prefix` the manifest lists.
void write_joined_index(const std::string& dir, const std::string& prefix) {
  std::vector<std::pair<long, std::string>> whole;
  for (const auto& n : read_manifest(dir)) {
    long s;
    int r;
    if (parse_name(n, prefix, s, r) && r < 0 && fs::exists(fs::path(dir) / n)) whole.emplace_back(s, n);
  }
  std::sort(whole.begin(), whole.end());
  whole.erase(std::unique(whole.begin(), whole.end()), whole.end());
  std::ostringstream x;
  for (const auto& [s, n] : whole) {
    const std::string path = (fs::path(dir) / n).string();
    H5Id f = open_ro(path);
    const auto t = get_attr(f.get(), "time");
    x << "   <Grid Name=\"" << prefix << "_" << step_tag(s) << "\" GridType=\"Uniform\">\n"
      << "    <Time Value=\"" << num(t.empty() ? double(s) : t[0]) << "\"/>\n";
    if (prefix == "particles" || H5Lexists(f.get(), "positions", H5P_DEFAULT) > 0) {
      const DsInfo pi = info_of(f.get(), "positions", path);
      const std::string ns = std::to_string(pi.dims.empty() ? 0 : pi.dims[0]);
      x << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << ns << "\" NodesPerElement=\"1\">\n"
        << "     <DataItem Dimensions=\"" << ns << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << n
        << ":/connectivity</DataItem>\n    </Topology>\n"
        << "    <Geometry GeometryType=\"XYZ\">\n     <DataItem Dimensions=\"" << ns
        << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << n << ":/positions</DataItem>\n    </Geometry>\n";
      for (const auto& d : dataset_names(f.get())) {
        if (d == "positions") continue;
        const DsInfo di = info_of(f.get(), d, path);
        xdmf_attr(x, "    ", d, di.dims.size() > 1 ? int(di.dims[1]) : 1, "Node", ns, n, int(di.bytes));
      }
    } else {
      const auto g = get_attr(f.get(), "global_cells"), o = get_attr(f.get(), "origin"), h = get_attr(f.get(), "spacing");
      if (g.size() != 3 || o.size() != 3 || h.size() != 1) throw Error("'" + path + "' lacks the piece attributes");
      xdmf_mesh(x, "    ", {long(g[0]), long(g[1]), long(g[2])}, {o[0], o[1], o[2]}, h[0]);
      const std::string dims = std::to_string(long(g[2])) + " " + std::to_string(long(g[1])) + " " + std::to_string(long(g[0]));
      for (const auto& d : dataset_names(f.get())) {
        const DsInfo di = info_of(f.get(), d, path);
        xdmf_attr(x, "    ", d, di.dims.size() > 3 ? int(di.dims[3]) : 1, "Cell", dims, n, int(di.bytes));
      }
    }
    x << "   </Grid>\n";
  }
  const std::string name = prefix + "_joined.xdmf";
  const auto listed = read_manifest(dir);
  bool recorded = std::find(listed.begin(), listed.end(), name) != listed.end();
  write_index(dir, name, prefix, recorded, {}, x.str());
}

}  // namespace

PieceInfo read_piece_info(const std::string& path, const std::string& dataset) {
  H5Id f = open_ro(path);
  PieceInfo p;
  const auto off = get_attr(f.get(), "piece_offset"), g = get_attr(f.get(), "global_cells");
  if (off.size() != 3 || g.size() != 3) throw Error("'" + path + "' is not a snapshot piece (no piece_offset)");
  const DsInfo d = info_of(f.get(), dataset, path);
  if (d.dims.size() < 3) throw Error("'" + path + "': dataset '" + dataset + "' is not a grid field");
  for (std::size_t a = 0; a < 3; ++a) {
    p.offset[a] = long(off[a]);
    p.global[a] = long(g[a]);
    p.cells[a] = long(d.dims[2 - a]);
  }
  const auto r = get_attr(f.get(), "rank"), R = get_attr(f.get(), "ranks");
  p.rank = r.empty() ? 0 : int(r[0]);
  p.ranks = R.empty() ? 1 : int(R[0]);
  return p;
}

std::vector<long> piece_steps(const std::string& dir, const std::string& prefix) {
  std::set<long> s;
  for (const auto& n : read_manifest(dir)) {
    long st;
    int r;
    if (parse_name(n, prefix, st, r) && r >= 0) s.insert(st);
  }
  return {s.begin(), s.end()};
}

std::string join_step(const std::string& dir, const std::string& prefix, long step, std::size_t* largest_values) {
  const std::string whole_name = prefix + "_" + step_tag(step) + ".h5";
  const std::string whole_path = (fs::path(dir) / whole_name).string();
  std::vector<std::string> pieces;
  const auto listed = read_manifest(dir);
  for (const auto& n : listed) {
    long s;
    int r;
    if (parse_name(n, prefix, s, r) && r >= 0 && s == step) {
      if (pieces.size() <= static_cast<std::size_t>(r)) pieces.resize(static_cast<std::size_t>(r) + 1);
      pieces[static_cast<std::size_t>(r)] = n;
    }
  }
  if (pieces.empty()) {
    if (fs::exists(whole_path)) {  // written uncut (one rank)
      write_joined_index(dir, prefix);
      return whole_path;
    }
    throw Error("join: no pieces of step " + std::to_string(step) + " of '" + prefix + "' in '" + dir + "'");
  }
  for (std::size_t r = 0; r < pieces.size(); ++r) {
    if (pieces[r].empty() || !fs::exists(fs::path(dir) / pieces[r]))
      throw Error("join: piece " + std::to_string(r) + " of step " + std::to_string(step) + " of '" + prefix +
                  "' is missing in '" + dir + "' (" + piece_file_name(prefix, step, int(r), int(pieces.size())) + ")");
  }
  std::size_t largest = 0;
  const std::string p0 = (fs::path(dir) / pieces[0]).string();
  H5Id f0 = open_ro(p0);
  const auto ranks = get_attr(f0.get(), "ranks");
  if (ranks.size() != 1 || long(ranks[0]) != long(pieces.size()))
    throw Error("join: '" + p0 + "' belongs to a run of " + (ranks.empty() ? std::string("?") : std::to_string(long(ranks[0]))) +
                " ranks, but " + std::to_string(pieces.size()) + " pieces of step " + std::to_string(step) + " are listed");
  const auto names = dataset_names(f0.get());
  std::vector<DsInfo> infos;
  for (const auto& n : names) infos.push_back(info_of(f0.get(), n, p0));
  const auto time = get_attr(f0.get(), "time");
  const bool grid = get_attr(f0.get(), "global_cells").size() == 3;
  if (std::find(listed.begin(), listed.end(), whole_name) == listed.end()) record_output_file(dir, whole_name);
  write_h5(whole_path, [&](hid_t out) {
    put_attr(out, whole_path, "time", {time.empty() ? double(step) : time[0]});
    put_attr(out, whole_path, "step", {double(step)});
    if (grid) {
      const auto g = get_attr(f0.get(), "global_cells");
      put_attr(out, whole_path, "global_cells", g);
      put_attr(out, whole_path, "piece_offset", {0, 0, 0});
      put_attr(out, whole_path, "origin", get_attr(f0.get(), "origin"));
      put_attr(out, whole_path, "spacing", get_attr(f0.get(), "spacing"));
      std::vector<H5Id> ds;
      for (std::size_t k = 0; k < names.size(); ++k) {
        std::vector<hsize_t> dims{hsize_t(g[2]), hsize_t(g[1]), hsize_t(g[0])};
        if (infos[k].dims.size() > 3) dims.push_back(infos[k].dims[3]);
        ds.push_back(make_dataset(out, whole_path, names[k], dims, infos[k].bytes == 4 ? H5T_IEEE_F32LE : H5T_IEEE_F64LE));
        put_units(ds.back().get(), whole_path, infos[k].units);
      }
      for (const auto& pn : pieces) {
        const std::string pp = (fs::path(dir) / pn).string();
        H5Id f = open_ro(pp);
        const auto off = get_attr(f.get(), "piece_offset");
        if (off.size() != 3) throw Error("join: '" + pp + "' lacks its piece_offset");
        for (std::size_t k = 0; k < names.size(); ++k) {
          const DsInfo di = info_of(f.get(), names[k], pp);
          if (di.dims.size() != infos[k].dims.size()) throw Error("join: '" + pp + "': dataset '" + names[k] + "' differs in rank");
          const std::vector<double> v = read_all(f.get(), names[k], pp);  // one piece's field
          largest = std::max(largest, v.size());
          std::vector<hsize_t> start{hsize_t(off[2]), hsize_t(off[1]), hsize_t(off[0])};
          std::vector<hsize_t> count{di.dims[0], di.dims[1], di.dims[2]};
          if (di.dims.size() > 3) {
            start.push_back(0);
            count.push_back(di.dims[3]);
          }
          // double -> the stored type (float32 or float64): exact for values read from that type.
          write_slab(ds[k].get(), whole_path, names[k], start, count, H5T_NATIVE_DOUBLE, v.data());
        }
      }
    } else {
      hsize_t total = 0;
      std::vector<hsize_t> counts;
      for (const auto& pn : pieces) {
        const std::string pp = (fs::path(dir) / pn).string();
        H5Id f = open_ro(pp);
        const DsInfo pi = info_of(f.get(), "positions", pp);
        counts.push_back(pi.dims.empty() ? 0 : pi.dims[0]);
        total += counts.back();
      }
      std::vector<H5Id> ds;
      for (std::size_t k = 0; k < names.size(); ++k) {
        std::vector<hsize_t> dims{total};
        if (infos[k].dims.size() > 1) dims.push_back(infos[k].dims[1]);
        ds.push_back(make_dataset(out, whole_path, names[k], dims, infos[k].bytes == 4 ? H5T_IEEE_F32LE : H5T_IEEE_F64LE));
      }
      H5Id conn = make_dataset(out, whole_path, "connectivity", {total}, H5T_STD_I64LE);
      hsize_t at = 0;
      for (std::size_t r = 0; r < pieces.size(); ++r) {
        const std::string pp = (fs::path(dir) / pieces[r]).string();
        H5Id f = open_ro(pp);
        for (std::size_t k = 0; k < names.size(); ++k) {
          const std::vector<double> v = read_all(f.get(), names[k], pp);
          largest = std::max(largest, v.size());
          std::vector<hsize_t> start{at}, count{counts[r]};
          if (infos[k].dims.size() > 1) {
            start.push_back(0);
            count.push_back(infos[k].dims[1]);
          }
          write_slab(ds[k].get(), whole_path, names[k], start, count, H5T_NATIVE_DOUBLE, v.data());
        }
        std::vector<std::int64_t> ids(static_cast<std::size_t>(counts[r]));
        for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<std::int64_t>(at + i);
        write_slab(conn.get(), whole_path, "connectivity", {at}, {counts[r]}, H5T_NATIVE_INT64, ids.data());
        at += counts[r];
      }
    }
  });
  write_joined_index(dir, prefix);
  if (largest_values) *largest_values = largest;
  return whole_path;
}

}  // namespace lbdem::io
