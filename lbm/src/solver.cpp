#include "lbm/solver.hpp"

#include <algorithm>
#include <stdexcept>

#include "core/error.hpp"
#include "population_stride.hpp"
#include "rest_state.hpp"

namespace lbdem::lbm {

std::unique_ptr<LbmSolver> make_solver_d2q9_f32(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d2q9_f64(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d3q19_f32(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d3q19_f64(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d2q9_f16s(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d2q9_f16c(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d3q19_f16s(const LbmSetup&, Backend);
std::unique_ptr<LbmSolver> make_solver_d3q19_f16c(const LbmSetup&, Backend);

int lattice_q(LatticeKind k) { return k == LatticeKind::D2Q9 ? 9 : 19; }
const char* to_string(LatticeKind k) { return k == LatticeKind::D2Q9 ? "D2Q9" : "D3Q19"; }
const char* to_string(Precision p) {
  switch (p) {
    case Precision::FP32: return "fp32";
    case Precision::FP64: return "fp64";
    case Precision::FP16S: return "fp16s";
    case Precision::FP16C: return "fp16c";
  }
  return "?";
}
Precision precision_from_string(const std::string& name) {
  for (Precision p : {Precision::FP32, Precision::FP64, Precision::FP16S, Precision::FP16C})
    if (name == to_string(p)) return p;
  throw ConfigError("precision '" + name + "': valid are fp32, fp64, fp16s (IEEE half storage) and fp16c (1-4-11 storage)");
}
int storage_bytes(Precision p) {
  switch (p) {
    case Precision::FP32: return 4;
    case Precision::FP64: return 8;
    case Precision::FP16S:
    case Precision::FP16C: return 2;
  }
  return 8;
}
const char* to_string(CollisionKind k) { return k == CollisionKind::BGK ? "bgk" : "trt"; }
const char* to_string(StreamKind k) { return k == StreamKind::AA ? "aa" : "two_lattice"; }

Index lbm_stage_cells(const LbmSetup& s) { return std::min<Index>(kOutputSlabCells, s.domain.view().n); }

MemoryUse lbm_memory(const LbmSetup& s) {
  const GridView g = s.domain.view();
  const std::size_t stride = static_cast<std::size_t>(population_stride(g.n));
  const auto tsize = static_cast<std::size_t>(storage_bytes(s.precision));
  const std::size_t lattices = s.streaming == StreamKind::AA ? 1 : 2;
  MemoryUse m;
  m.add("populations", stride * static_cast<std::size_t>(lattice_q(s.lattice)) * tsize * lattices);
  m.add("flags", static_cast<std::size_t>(g.n));
  m.add("output staging", 4 * static_cast<std::size_t>(lbm_stage_cells(s)) * sizeof(double));
  return m;
}

std::size_t lbm_memory_estimate(const LbmSetup& s) { return lbm_memory(s).total(); }

std::unique_ptr<LbmSolver> make_lbm_solver(const LbmSetup& s, Backend b) {
  if (s.tau <= 0.5) throw ConfigError("tau = " + std::to_string(s.tau) + ": must be > 0.5 (viscosity (tau-1/2)/3 > 0)");
  if (s.collision == CollisionKind::TRT && !(s.magic > 0))
    throw ConfigError("TRT magic parameter = " + std::to_string(s.magic) + ": must be > 0 (3/16 exact walls, 1/4 most stable)");
  if (s.lattice == LatticeKind::D2Q9 && s.domain.local[2] != 1)
    throw ConfigError("D2Q9 needs nz = 1, got " + std::to_string(s.domain.local[2]));
  if (s.boundaries.count > kMaxBoundaries)
    throw ConfigError("at most " + std::to_string(kMaxBoundaries) + " boundary kinds per case");
  try {
    s.domain.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(e.what());
  }
  const bool d2 = s.lattice == LatticeKind::D2Q9;
  switch (s.precision) {
    case Precision::FP32: return d2 ? make_solver_d2q9_f32(s, b) : make_solver_d3q19_f32(s, b);
    case Precision::FP16S: return d2 ? make_solver_d2q9_f16s(s, b) : make_solver_d3q19_f16s(s, b);
    case Precision::FP16C: return d2 ? make_solver_d2q9_f16c(s, b) : make_solver_d3q19_f16c(s, b);
    case Precision::FP64: break;
  }
  return d2 ? make_solver_d2q9_f64(s, b) : make_solver_d3q19_f64(s, b);
}

void initialize_at_rest(LbmSolver& s, const std::vector<std::uint8_t>& flags, double rho,
                        const std::vector<CellBox>& unit_density) {
  if (auto* own = dynamic_cast<RestStateInit*>(&s)) {
    own->initialize_at_rest(flags, rho, unit_density);
    return;
  }
  // The fields initialize() takes, on the host.
  const GridView g = s.setup().domain.view();
  std::vector<double> r(static_cast<std::size_t>(g.n), rho), u(3 * static_cast<std::size_t>(g.n), 0.0);
  for (const CellBox& b : unit_density)
    for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
      for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
        for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x) r[static_cast<std::size_t>(g.index(x, y, z))] = 1.0;
  s.initialize(flags, r, u);
}

}  // namespace lbdem::lbm
