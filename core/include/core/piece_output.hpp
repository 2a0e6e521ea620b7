#pragma once
// Snapshots of a grid and of particles cut into pieces, one piece per rank,
// written without gathering anything: every rank writes its own owned box of
// each field (and the particles it owns) to its own HDF5 file, and rank 0
// writes one XDMF index whose every step is a spatial collection of the
// pieces, which ParaView opens as one grid. Nothing here calls MPI: the caller
// orders the collective steps (see "Protocol" below). One rank is the
// one-piece case of the same code.
//
// Files of a run folder (see README "Reading the output"):
//   <prefix>_<step:08d>.h5             the step's one piece when the grid is not cut
//   <prefix>_<step:08d>_r<rank>.h5     piece of rank <rank> (4 digits or more) when it is
//   <prefix>.xdmf                      temporal collection of spatial collections
//   <prefix>_<step:08d>.h5 after `lbdem join` (join_step below): the whole grid
//   (or all particles) of a cut step, the layout of an uncut run; indexed by
//   <prefix>_joined.xdmf.
// A field piece holds the datasets of the whole-grid file (shape (nz, ny, nx[,
// components]) of the piece's owned cells), stored as float32 or float64 as
// asked, and the attributes time, step, piece_offset (x y z of its first cell
// in the whole grid), global_cells (x y z), origin (x y z, metres), spacing,
// rank and ranks. A particle piece holds the particles the rank owns, in its
// storage order, with the datasets of ParticleWriter (connectivity 0..n-1 of
// the piece) and the attributes time, step, rank and ranks.
//
// Protocol of one snapshot on R ranks (collective in the caller):
//   1. rank 0: record(step) names all R piece files in the run manifest
//      (core/output.hpp), so `--overwrite` and a restart find every one;
//   2. barrier; 3. every rank: write_piece(...);
//   4. the particle counts gathered to rank 0 (this also orders 3 before 5);
//   5. rank 0: index(step, time[, counts]) rewrites the XDMF index.
// Every file goes through a temporary name and a rename (core/output.hpp).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/grid.hpp"
#include "core/output.hpp"

namespace lbdem::io {

// One rank's owned box in whole-grid cells.
struct PieceBox {
  std::array<long, 3> offset{0, 0, 0};
  std::array<long, 3> cells{1, 1, 1};
};

// The file of piece `rank` of `ranks` at `step` ("<prefix>_<step:08d>.h5" for one piece).
std::string piece_file_name(const std::string& prefix, long step, int rank, int ranks);

class PieceGridWriter {
 public:
  // whole: the whole grid (extent, origin, spacing); pieces: every rank's owned
  // box (index = rank); rank: this rank; owned: this rank's owned cells in the
  // storage coordinates the fill callback is handed (Grid::owned() of its piece).
  PieceGridWriter(std::string dir, std::string prefix, const Grid& whole, std::vector<PieceBox> pieces, int rank,
                  CellBox owned);
  void set_float32(bool on) { fp32_ = on; }
  bool float32() const { return fp32_; }
  // Rank 0: names every piece file of `step` in the manifest (steps 1 of the protocol).
  void record(long step);
  // This rank's piece, slab by slab: `fill` is handed boxes (storage
  // coordinates, within `owned`) of at most slab_cells cells and fills every
  // field's values for them (box x-fastest, components side by side), which go
  // to the piece's datasets as hyperslabs. Host memory: one slab per field,
  // kept between calls. A box beyond the piece is refused. Returns the path.
  std::string write_piece(long step, double time, const std::vector<SlabField>& fields, Index slab_cells,
                          const SlabFill& fill);
  // Rank 0: adds (or replaces) the step in the index and rewrites it.
  void index(long step, double time, const std::vector<SlabField>& fields);
  // Restart: keeps the index's entries of steps <= up_to_step.
  void resume(long up_to_step);
  // The largest host buffer (values) write_piece has held: at most slab_cells x components.
  std::size_t largest_buffer_values() const { return largest_; }

 private:
  std::string dir_, prefix_;
  Grid whole_;
  std::vector<PieceBox> pieces_;
  int rank_;
  CellBox owned_;
  bool fp32_ = false;
  bool xdmf_recorded_ = false;
  std::vector<std::vector<double>> slab_;
  std::vector<float> slab32_;  // float32 files: a field's slab rounded here, written as it is stored
  std::size_t largest_ = 0;
  struct Entry {
    long step;
    double time;
    std::vector<std::pair<std::string, int>> fields;
    int bytes;
  };
  std::vector<Entry> entries_;
  std::vector<std::pair<long, std::string>> carried_;
};

class PieceParticleWriter {
 public:
  PieceParticleWriter(std::string dir, std::string prefix, int rank, int ranks);
  void record(long step);
  // This rank's particles: positions 3n (x y z interleaved) and the fields (n x components each).
  std::string write_piece(long step, double time, long n, const double* positions,
                          const std::vector<ParticleField>& fields);
  // Rank 0: counts[r] particles in piece r.
  void index(long step, double time, const std::vector<long>& counts, const std::vector<std::pair<std::string, int>>& fields);
  void resume(long up_to_step);

 private:
  std::string dir_, prefix_;
  int rank_, ranks_;
  bool xdmf_recorded_ = false;
  struct Entry {
    long step;
    double time;
    std::vector<long> counts;
    std::vector<std::pair<std::string, int>> fields;
  };
  std::vector<Entry> entries_;
  std::vector<std::pair<long, std::string>> carried_;
};

// The attributes of a field piece (or a joined file): its offset and cells in
// the whole grid, the whole grid's cells, rank and ranks. An Error when the
// file is not a piece.
struct PieceInfo {
  std::array<long, 3> offset{0, 0, 0}, cells{0, 0, 0}, global{0, 0, 0};
  int rank = 0, ranks = 1;
};
PieceInfo read_piece_info(const std::string& path, const std::string& dataset = "density");

// Steps of `prefix` whose pieces the folder's manifest lists (ascending).
std::vector<long> piece_steps(const std::string& dir, const std::string& prefix);

// Joins the pieces of `step` of `prefix` ("fields": a grid, "particles":
// points) in `dir` into <prefix>_<step:08d>.h5 (named in the manifest, written
// through a temporary) and rewrites <prefix>_joined.xdmf over every joined or
// uncut step. Streams: one piece's dataset in memory at a time, written as a
// hyperslab of the whole file. A step written uncut (one rank) is left as it
// is. Returns the whole file's path; a missing or inconsistent piece is an
// Error naming it. largest_values (optional): the largest buffer it held.
std::string join_step(const std::string& dir, const std::string& prefix, long step,
                      std::size_t* largest_values = nullptr);

}  // namespace lbdem::io
