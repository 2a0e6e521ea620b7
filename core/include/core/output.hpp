#pragma once
// Results users open in ParaView: HDF5 files with an XDMF index, plus CSV
// time series. All data handed in is on the host (copy it down first).
//
// Layout of a run folder (see README "Reading the output"):
//   <dir>/<prefix>_<step:08d>.h5   one file per output step
//   <dir>/<prefix>.xdmf            temporal collection of all of them (rewritten each output)
//   <dir>/<name>.csv               scalar time series, one row per sample
#include <array>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace lbdem::io {

// A cell-centred field on a structured grid: nx*ny*nz values (x fastest) times
// `components` (1 scalar, 3 vector: interleaved xyz per cell).
struct GridField {
  std::string name;
  int components = 1;
  const double* data = nullptr;  // host, size nx*ny*nz*components
  std::string units;             // stored as an HDF5 attribute
};

// Structured grid output (2D grids use nz = 1).
class GridWriter {
 public:
  // dims: cells per axis; origin: position of the first cell centre minus half
  // a spacing (i.e. the domain corner), spacing: cell size, all in metres.
  GridWriter(std::string dir, std::string prefix, std::array<long, 3> dims, std::array<double, 3> origin,
             std::array<double, 3> spacing);
  // Writes one step; fields are written as float64 datasets of shape
  // (nz, ny, nx[, components]). Returns the .h5 path.
  std::string write(long step, double time, const std::vector<GridField>& fields);
  const std::vector<std::string>& files() const { return files_; }

 private:
  void write_xdmf() const;
  std::string dir_, prefix_;
  std::array<long, 3> dims_;
  std::array<double, 3> origin_, spacing_;
  struct Entry { long step; double time; std::string file; std::vector<std::pair<std::string, int>> fields; };
  std::vector<Entry> entries_;
  std::vector<std::string> files_;
};

// Particle output: points with radius, velocity and any extra per-particle
// scalar/vector attributes; ParaView shows them as points (glyph by radius).
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

 private:
  void write_xdmf() const;
  std::string dir_, prefix_;
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
  std::ofstream out_;
  std::size_t ncols_ = 0;
};

// Reads a dataset back (tests, restart tools). Returns the flat values.
std::vector<double> read_dataset(const std::string& h5_path, const std::string& name);

// Output-folder policy: creates `dir` if needed; if it already holds files and
// overwrite is false, throws ConfigError naming the folder and --overwrite.
// If it cannot be written, throws ConfigError naming it. Never deletes files
// unless overwrite is true (then only files this engine writes: *.h5, *.xdmf,
// *.csv, *.json, *.log).
void prepare_output_dir(const std::string& dir, bool overwrite);

}  // namespace lbdem::io
