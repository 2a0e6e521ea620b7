#pragma once
// Private state of DemSystem, shared by its kernel translation units.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "dem/system.hpp"
#include "kernels.hpp"

namespace lbdem {
struct Scratch;  // core/algorithms.hpp (kernel TUs only)
}

namespace lbdem::dem {

struct DemSystem::Impl {
  ~Impl();  // frees the page-locked mirror and the events (system.cu)
  Exec ex;
  DemParams p;
  Box box;
  Walls walls;
  ContactLaw pp, pw;
  Grid grid;
  Index n = 0;
  int cap = 0;        // neighbour-list slots per particle
  double skin = 0;
  double time = 0;
  long steps = 0, rebuilds = 0;
  bool forces_valid = false;
  bool old_valid = false;  // frco/trqo hold a_{n-1} of the current trajectory
  bool have_cells = false;  // key_sorted holds the previous build's keys

  // Particle arrays and their reorder twins (swapped at each rebuild).
  Buffer<Real4> pos, vel, omg, frc, trq, frco, trqo, vpr, wpr, extf, extt, x0;
  Buffer<Real4> pos2, vel2, omg2, frc2, trq2, frco2, trqo2, vpr2, wpr2, extf2, extt2;
  Buffer<std::int64_t> gid, gid2;
  Buffer<int> type, type2;
  Buffer<Vec3d> whist, whist2;  // wall histories [w * n + i] (friction)

  // Cell list.
  Buffer<std::uint32_t> key, key_sorted;
  Buffer<int> idx, perm;  // perm[new] = old index of the last rebuild
  Buffer<int> cell_start, cell_end;
  // Verlet list, column-major: slot s of particle i at [s * n + i].
  Buffer<int> nbr, ncount, nbr_prev, ncount_prev;
  Buffer<Vec3d> hist, hist_prev;
  bool have_prev = false;
  // Contact pairs (pair path): count -> exclusive scan -> fill.
  Buffer<int> ccount, coffs;
  Buffer<PairIJ> pairs;
  // flags[0] list overflow, [1] largest neighbour count seen (read at each build).
  Buffer<int> flags;

  // Rebuild decisions (system.cu, "Rebuild decisions"). Report q is reduced
  // into device slot q % kRing, copied to mirror[q % kRing] on the stream,
  // and events[q % kRing] is recorded after the copy.
  static constexpr int kRing = 4;
  Buffer<StatusRecord> status;         // kRing slots + one sink slot (bench hook), zeroed at start
  StatusRecord* mirror = nullptr;      // host copies: page-locked (CUDA) or mirror_host's storage
  std::vector<StatusRecord> mirror_host;
#if defined(LBDEM_HAVE_CUDA)
  cudaEvent_t events[kRing] = {};
#endif
  struct Pending {
    long from, t;  // the steps it covers (over2) and the state it reports
    long due;      // read before deciding the step that produces this state
    int slot;
  };
  Pending pending[kRing] = {};  // oldest first
  int npending = 0;
  long reports = 0;             // reports taken so far (the next one uses slot reports % kRing)
  long t_last_report = 0;       // state (step count) of the last report taken
  int report_every = 1;         // steps between reports inside a call, and their lag
  // The last report read: state t_known, largest displacement since the
  // build [m], speed [m/s] and acceleration [m/s^2] there.
  bool known = false;
  long t_known = 0;
  double d_known = 0, v_known = 0, a_known = 0;
  long t_build = 0;  // state (step count) of the last list build
  long status_reads = 0, status_waits = 0;
  std::string stale_error;  // set once a stale list was reported: advance() refuses until rebuild()
  std::unique_ptr<Scratch> scratch_ptr;  // complete type in the .cu TUs only
  Scratch& scratch() { return *scratch_ptr; }

  State state() const {
    State s;
    s.pos = pos.data(); s.vel = vel.data(); s.omg = omg.data(); s.frc = frc.data(); s.trq = trq.data();
    s.frc_old = frco.data(); s.trq_old = trqo.data();
    s.vpr = vpr.data(); s.wpr = wpr.data();
    s.extf = extf.data(); s.extt = extt.data(); s.x0 = x0.data(); s.gid = gid.data();
    s.nbr = nbr.data(); s.ncount = ncount.data(); s.n = n; s.cap = cap;
    s.hist = hist.data(); s.whist = whist.data();
    s.box = box; s.walls = walls; s.pp = pp; s.pw = pw;
    s.gravity = p.gravity; s.body = p.body_force; s.dt = p.dt;
    s.half_skin2 = 0.25 * skin * skin;
    s.skin = skin;
    s.flags = flags.data();
    return s;
  }
};

// Reports that arrived after a full synchronisation: throws DivergenceError
// if one shows a stale list (system.cu).
void check_arrived_reports(DemSystem::Impl& m);

// Force evaluation, one instantiation per friction flag (own TU each).
void run_forces_frictionless(DemSystem::Impl& m);
void run_forces_frictional(DemSystem::Impl& m);

}  // namespace lbdem::dem
