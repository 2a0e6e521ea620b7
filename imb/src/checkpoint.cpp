// The coupled scene's checkpoint (imb/checkpoint.hpp).
#include "imb/checkpoint.hpp"

#include <exception>

#include "dem/system.hpp"
#include "imb/coupled.hpp"

namespace lbdem::imb {

using halo::agree;
using halo::BytesSource;
using halo::file_ranks;
using halo::load_run_shared;
using halo::SharedWriter;
using lbm::load_fluid_shared;
using lbm::save_fluid_piece;
using dem::load_dem_shared;

void save_coupled(ckpt::Writer& w, lbm::LbmSolver& fluid, const dem::DemSystem& dem, const CoupledSolver& cs,
                  const RunValues& values) {
  halo::save_sections(w, values, halo::section("lbm", fluid), halo::section("dem", dem), halo::section("coupling", cs));
}

RunValues load_coupled(ckpt::Reader& r, lbm::LbmSolver& fluid, dem::DemSystem& dem, CoupledSolver& cs) {
  return halo::load_sections(r, halo::section("lbm", fluid), halo::section("dem", dem), halo::section("coupling", cs));
}

void save_coupled(ckpt::Run& run, const halo::Comm& comm, long step, double time, lbm::LbmSolver& fluid,
                  const dem::DemSystem& dem, const CoupledSolver& cs, const RunValues& values) {
  if (!comm.distributed()) {
    run.write(step, time, [&](ckpt::Writer& w) { save_coupled(w, fluid, dem, cs, values); });
    return;
  }
  SharedWriter w(run, comm, step, time);
  w.root_section("run", [&](ckpt::Sink& out) { out.put_vector(values); });
  w.rank_sections("lbm", [&](ckpt::Sink& out) { save_fluid_piece(out, fluid); });
  w.rank_sections("dem", [&](ckpt::Sink& out) { dem.save_state(out); }, true);
  w.root_section("coupling", [&](ckpt::Sink& out) { cs.save_state(out); });
  w.commit();
}

RunValues load_coupled(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags, dem::DemSystem& dem, CoupledSolver& cs,
                       const std::string& dims) {
  if (!comm.distributed() && file_ranks(run.reader()) == 1) return load_coupled(run.reader(), fluid, dem, cs);
  RunValues v = load_run_shared(run, comm);
  load_fluid_shared(run, comm, fluid, whole, flags);
  load_dem_shared(run, comm, dem, dims);
  // The coupling's step count (the same on every rank): rank 0 reads it.
  std::vector<std::byte> bytes;
  std::exception_ptr failed;
  if (comm.root()) {
    try {
      ckpt::Reader& r = run.reader();
      r.section("coupling");
      bytes.resize(sizeof(std::int64_t));
      r.read(bytes.data(), bytes.size());
      r.finish();
    } catch (...) {
      failed = std::current_exception();
    }
  }
  agree(comm, failed, "read the checkpoint");
  comm.broadcast(bytes, 0);
  BytesSource src(bytes);
  cs.load_state(src);
  return v;
}

}  // namespace lbdem::imb
