#pragma once
// Results users open in ParaView: HDF5 files with an XDMF index, plus CSV
// time series. All data handed in is on the host (copy it down first).
//
// Layout of a run folder (see README "Reading the output"):
//   <dir>/<prefix>_<step:08d>.h5   one file per output step
//   <dir>/<prefix>.xdmf            temporal collection of all of them (rewritten each output)
//   <dir>/<name>.csv               scalar time series, one row per sample
//   <dir>/.lbdem_manifest          the name of every file lbdem wrote in <dir>, one per line
//
// Every writer here names its file in the folder's manifest before creating
// it, so `--overwrite` (prepare_output_dir) can remove exactly what lbdem
// wrote and nothing of the user's. HDF5 files, the XDMF index and
// write_text_atomically() go through a temporary name in the same folder and a
// rename once complete: a killed run never leaves a truncated file under a
// final name, and a failed write removes its temporary. Write failures throw
// one line naming the file and the system error (ResourceError when the disk
// or quota is full, lbdem::Error otherwise); the HDF5 error stack is not printed.
#include <array>
#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/grid.hpp"
#include "core/memory_use.hpp"

namespace lbdem::io {

// A cell-centred field on a structured grid: nx*ny*nz values (x fastest) times
// `components` (1 scalar, 3 vector: interleaved xyz per cell).
struct GridField {
  std::string name;
  int components = 1;
  const double* data = nullptr;  // host, size nx*ny*nz*components
  std::string units;             // stored as an HDF5 attribute
};

// A field written slab by slab (GridWriter::write_slabs).
struct SlabField {
  std::string name;
  int components = 1;
  std::string units;
};
// Fills the values of every field for the cells of `box` (global cell
// coordinates): out[f] receives box.size() * components doubles, box
// x-fastest, a cell's components side by side.
using SlabFill = std::function<void(const CellBox& box, const std::vector<double*>& out)>;

// Structured grid output (2D grids use nz = 1).
class GridWriter {
 public:
  // dims: cells per axis; origin: position of the first cell centre minus half
  // a spacing (i.e. the domain corner), spacing: cell size, all in metres.
  GridWriter(std::string dir, std::string prefix, std::array<long, 3> dims, std::array<double, 3> origin,
             std::array<double, 3> spacing);
  // The grid's global extent, origin and spacing (core/grid.hpp). Fields are
  // handed in over the grid's storage cells; this writer takes a whole grid
  // (one rank); a piece of a decomposed grid is refused with a ConfigError.
  GridWriter(std::string dir, std::string prefix, const Grid& grid);
  // Writes one step; fields are written as float64 datasets of shape
  // (nz, ny, nx[, components]). Returns the .h5 path.
  std::string write(long step, double time, const std::vector<GridField>& fields);
  // Writes one step slab by slab: the grid is cut into boxes of at most
  // slab_cells cells (slabs_of, core/memory_use.hpp); for each box `fill`
  // hands in every field's values, which go to the file as hyperslabs of
  // the same datasets write() makes. Host memory: one slab per field, kept
  // between calls; no whole-grid array anywhere. Returns the .h5 path.
  std::string write_slabs(long step, double time, const std::vector<SlabField>& fields, Index slab_cells,
                          const SlabFill& fill);
  // Store fields as float32 (HDF5 rounds the doubles handed in; the XDMF
  // index says Precision 4): half the disk for a run whose populations are
  // fp32 anyway. Default float64.
  void set_float32(bool on) { fp32_ = on; }
  bool float32() const { return fp32_; }
  const std::vector<std::string>& files() const { return files_; }
  // Restart (core/checkpoint.hpp): keeps the entries of steps <= up_to_step
  // of the folder's existing .xdmf index, so that it goes on listing them.
  void resume(long up_to_step);

 private:
  void write_xdmf();
  std::vector<unsigned long long> shape(int components) const;  // (nz, ny, nx[, components])
  // Creates the step's file; `body` writes its datasets into the open file.
  std::string write_file(long step, double time, const std::vector<std::pair<std::string, int>>& fields,
                         const std::function<void(std::int64_t, const std::string&)>& body);
  bool fp32_ = false;
  std::vector<std::vector<double>> slab_;  // write_slabs: one slab per field
  std::vector<std::pair<long, std::string>> carried_;  // resume(): earlier entries, as XDMF text
  std::string dir_, prefix_;
  bool xdmf_recorded_ = false;  // the .xdmf name is in the manifest
  std::array<long, 3> dims_;
  std::array<double, 3> origin_, spacing_;
  struct Entry {
    long step;
    double time;
    std::string file;
    std::vector<std::pair<std::string, int>> fields;
    int bytes;  // per stored value: 8 float64, 4 float32
  };
  std::vector<Entry> entries_;
  std::vector<std::string> files_;
};

// Particle output: points with radius, velocity and any extra per-particle
// scalar/vector attributes; ParaView shows them as points (glyph by radius).
// Each file also holds `connectivity` (0..n-1, int64), the Polyvertex
// topology's data item: ParaView's Xdmf3 readers count the points' cells from it.
struct ParticleField {
  std::string name;
  int components = 1;
  const double* data = nullptr;  // host, n*components
};
class ParticleWriter {
 public:
  ParticleWriter(std::string dir, std::string prefix);
  // positions: 3n values (x,y,z interleaved). Returns the .h5 path.
  std::string write(long step, double time, long n, const double* positions,
                    const std::vector<ParticleField>& fields);
  // Restart: as GridWriter::resume.
  void resume(long up_to_step);

 private:
  void write_xdmf();
  std::vector<std::pair<long, std::string>> carried_;
  std::string dir_, prefix_;
  bool xdmf_recorded_ = false;
  struct Entry { long step; double time; long n; std::string file; std::vector<std::pair<std::string, int>> fields; };
  std::vector<Entry> entries_;
};

// CSV time series with a header line; each row is flushed so a crashed run
// keeps everything up to its last sample.
class TimeSeries {
 public:
  TimeSeries() = default;
  TimeSeries(const std::string& path, std::vector<std::string> columns);
  void append(const std::vector<double>& values);
  bool is_open() const { return out_.is_open(); }

 private:
  std::string path_;
  std::ofstream out_;
  std::size_t ncols_ = 0;
};

// Writes `text` to `path` through a temporary file in the same folder and a
// rename, after naming the file in the folder's manifest (summary.json, ...).
void write_text_atomically(const std::string& path, const std::string& text);

// Names `name` (a plain file name) in the manifest of `dir`, before the file
// is created (writers outside this file: core/piece_output.hpp).
void record_output_file(const std::string& dir, const std::string& name);
// Replaces `path` with `text` through a temporary and a rename, without
// naming it in the manifest (the caller recorded it once).
void replace_file_atomically(const std::string& path, const std::string& text);

// The run manifest of an output folder: file name and the names it lists
// (empty when there is none). Names are plain file names in that folder.
inline constexpr const char* kManifestName = ".lbdem_manifest";
std::vector<std::string> read_manifest(const std::string& dir);

// Reads a dataset back (tests, restart tools). Returns the flat values.
std::vector<double> read_dataset(const std::string& h5_path, const std::string& name);

// How the datasets of two HDF5 files (whole-grid snapshots of two runs, e.g. a
// run and its restart on other ranks or another backend) differ: every dataset
// at the root of `a`, against the one of that name in `b` (missing or another
// size: an Error naming it). `max_abs` is the largest |a - b| over the values,
// `scale` the largest |a|, so max_abs / scale is the difference relative to the
// field's size; `bitwise` holds when every value has the same bits.
struct DatasetDiff {
  std::string name;
  std::size_t values = 0;
  bool bitwise = true;
  double max_abs = 0, scale = 0;
};
std::vector<DatasetDiff> compare_datasets(const std::string& a, const std::string& b);

// Output-folder policy, applied before a run writes anything:
//  - creates `dir` if needed; an empty string, a non-folder or an unwritable
//    folder is a ConfigError naming it;
//  - a folder holding files (the manifest aside) needs overwrite; without it,
//    ConfigError naming the folder and --overwrite;
//  - with overwrite, removes exactly the regular files named in the folder's
//    manifest (and temporaries of those names left by a killed run). Anything
//    else in the folder (the user's files, hidden files, symlinks, folders, or
//    every file when there is no manifest, as after an older lbdem) is named in
//    a ConfigError and nothing is deleted. Symlinks are never followed.
// Leaves a fresh manifest in the folder.
void prepare_output_dir(const std::string& dir, bool overwrite);
// The checks of prepare_output_dir that only read (what `lbdem check` runs):
// refuses with the same ConfigError what prepare_output_dir would refuse that
// can be known without writing (an empty name, a non-folder, a folder that
// cannot be created or written to as far as its file system and permissions
// say, a non-empty folder without overwrite, foreign entries with it),
// creating and changing nothing. Returns the files overwrite would remove.
std::vector<std::string> check_output_dir(const std::string& dir, bool overwrite);

}  // namespace lbdem::io
