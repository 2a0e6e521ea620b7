#pragma once
// A fluid solver spread over the ranks with its halo exchange, global
// diagnostics and whole-grid output on rank 0. On one rank it is the plain
// solver (no ghost layers, no exchange, the same bits as before). The
// `parallel` section of a case file is read by halo/parallel_options.hpp.
#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/piece_output.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/parallel_options.hpp"
#include "halo/transport.hpp"
#include "lbm/halo_exchange.hpp"
#include "lbm/solver.hpp"

namespace lbdem::lbm {

class DistributedFluid {
 public:
  // `whole` describes the whole grid (Grid::whole). Refuses (ConfigError) a
  // rank count or decomposition that cannot work, before allocating.
  DistributedFluid(const LbmSetup& whole, Backend backend, const halo::ParallelOptions& po, const halo::Comm& comm);
  // Whole-grid fields (the same on every rank); each rank keeps its piece.
  void initialize(const std::vector<std::uint8_t>& flags, const std::vector<double>& rho, const std::vector<double>& u);
  // The same state built on each rank for its piece alone (no whole-grid
  // field anywhere): flag(x, y, z) gives the flag of a whole-grid cell
  // (global coordinates inside the grid; called from several threads at
  // once, so it must only read), every cell at rest at density rho; the
  // density and velocity are made on the solver's backend.
  // Bit for bit the state initialize() makes from the whole-grid fields.
  void initialize_uniform(const std::function<std::uint8_t(long, long, long)>& flag, double rho);
  void step(long n);
  // Sums and extremes over all ranks; cells in whole-grid coordinates; every
  // rank gets the same values (collective), so a watchdog on them stops all
  // ranks at the same step.
  LbmDiagnostics diagnostics();
  // The ranks holding the cells the last diagnostics() named: the fastest
  // cell, and the first non-finite cell (-1: none). 0 on one rank.
  int max_speed_rank() const { return max_speed_rank_; }
  int nonfinite_rank() const { return nonfinite_rank_; }
  // Whole-grid fields on rank 0 (empty on the others).
  void macroscopic(std::vector<double>& rho, std::vector<double>& u);
  // A field of `comps` values per cell given by each rank for its owned cells
  // (owned box x-fastest, components innermost), as the whole grid's on rank
  // 0 (cells nobody owns: `fill` (one value per component), else 0; empty on
  // the other ranks). Collective.
  std::vector<double> gather_owned(const std::vector<double>& mine, int comps, const std::vector<double>& fill = {});
  // Every rank's owned box in whole-grid cells (index = rank): the pieces of
  // the snapshot output (core/piece_output.hpp), known on every rank without
  // any exchange.
  std::vector<io::PieceBox> piece_boxes() const;
  void synchronize() { solver_->synchronize(); }
  std::size_t memory_bytes() const;  // all ranks
  LbmSolver& local() { return *solver_; }
  const halo::Decomposition& decomposition() const { return dec_; }
  const halo::Comm& comm() const { return comm_; }
  bool distributed() const { return comm_.distributed(); }
  const FluidHalo* halo() const { return halo_.get(); }
  FluidHalo* halo() { return halo_.get(); }
  std::string describe() const;  // "2 x 1 x 1 ranks, host_mpi" / "1 rank"

 private:
  const halo::Comm& comm_;
  LbmSetup whole_;
  halo::Decomposition dec_;
  std::unique_ptr<LbmSolver> solver_;
  std::unique_ptr<halo::Transport> transport_;
  std::unique_ptr<FluidHalo> halo_;
  int max_speed_rank_ = 0, nonfinite_rank_ = -1;
};

// Per-rank memory the fluid of `whole` needs on `ranks` ranks (the largest piece).
std::size_t distributed_fluid_memory(const LbmSetup& whole, const halo::ParallelOptions& po, int ranks);

}  // namespace lbdem::lbm
