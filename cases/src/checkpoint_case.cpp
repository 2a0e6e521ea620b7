// The checkpoint side of the scene drivers (cases/src/checkpoint_case.hpp).
#include "checkpoint_case.hpp"

#include <algorithm>
#include <cstring>
#include <exception>
#include <functional>
#include <span>

#include "core/error.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "lbm/boundary.hpp"

namespace lbdem::cases {

namespace {

void save_run(ckpt::Writer& w, const RunValues& values) {
  w.section("run");
  w.put_vector(values);
}

RunValues load_run(ckpt::Reader& r) {
  r.section("run");
  return r.get_vector<double>(1 << 16);
}

}  // namespace

ckpt::Identity fluid_identity(const std::string& scene, const lbm::LbmSetup& s) {
  const auto& g = s.domain.global;
  const auto& p = s.domain.periodic;
  ckpt::Identity id;
  id.add("scene", scene)
      .add("lattice", lbm::to_string(s.lattice))
      .add("precision", lbm::to_string(s.precision))
      .add("streaming", lbm::to_string(s.streaming))
      .add("collision", lbm::to_string(s.collision))
      .add("grid", std::to_string(g[0]) + "x" + std::to_string(g[1]) + "x" + std::to_string(g[2]))
      .add("periodic", std::string(p[0] ? "1" : "0") + (p[1] ? "1" : "0") + (p[2] ? "1" : "0"));
  return id;
}

void save_coupled(ckpt::Writer& w, lbm::LbmSolver& fluid, const dem::DemSystem& dem, const imb::CoupledSolver& cs,
                  const RunValues& values) {
  save_run(w, values);
  w.section("lbm");
  fluid.save_state(w);
  w.section("dem");
  dem.save_state(w);
  w.section("coupling");
  cs.save_state(w);
}

RunValues load_coupled(ckpt::Reader& r, lbm::LbmSolver& fluid, dem::DemSystem& dem, imb::CoupledSolver& cs) {
  RunValues v = load_run(r);
  r.section("lbm");
  fluid.load_state(r);
  r.section("dem");
  dem.load_state(r);
  r.section("coupling");
  cs.load_state(r);
  r.finish();
  return v;
}

void save_fluid(ckpt::Writer& w, lbm::LbmSolver& fluid, const RunValues& values) {
  save_run(w, values);
  w.section("lbm");
  fluid.save_state(w);
}

RunValues load_fluid(ckpt::Reader& r, lbm::LbmSolver& fluid) {
  RunValues v = load_run(r);
  r.section("lbm");
  fluid.load_state(r);
  r.finish();
  return v;
}

void save_dem(ckpt::Writer& w, const dem::DemSystem& dem, const RunValues& values) {
  save_run(w, values);
  w.section("dem");
  dem.save_state(w);
}

RunValues load_dem(ckpt::Reader& r, dem::DemSystem& dem) {
  RunValues v = load_run(r);
  r.section("dem");
  dem.load_state(r);
  r.finish();
  return v;
}

io::TimeSeries open_series(const ckpt::Run& run, const std::string& path, const std::vector<std::string>& columns,
                           long interval) {
  const auto rows = run.kept_rows(path, columns, interval);
  io::TimeSeries ts(path, columns);
  for (const auto& row : rows) ts.append(row);
  return ts;
}

void refuse_distributed(const std::string& scene, const std::optional<std::string>& restart, ckpt::Policy& p,
                        bool distributed) {
  if (!distributed) return;
  if (restart)
    throw ConfigError("--restart: the " + scene + " scene on several ranks cannot be restarted yet (the fluid scenes "
                      "can); restart on one rank");
  if (p.interval > 0 || p.minutes > 0)
    throw ConfigError("checkpoint: the " + scene + " scene on several ranks cannot write checkpoints yet (the fluid "
                      "scenes can); leave out the checkpoint section or run on one rank");
  p.on_signal = false;
}

void prepare_output_on_writer(ckpt::Run& run, bool writer, const halo::Comm& comm, bool overwrite,
                              const std::string& outdir) {
  std::exception_ptr failed;
  if (writer) {
    try {
      run.prepare_output(overwrite);
    } catch (...) {
      failed = std::current_exception();
    }
  }
  if (comm.any(failed != nullptr)) {
    if (failed) std::rethrow_exception(failed);
    throw Error("rank 0 could not prepare the output directory " + outdir);
  }
}

}  // namespace lbdem::cases
