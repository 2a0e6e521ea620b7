#pragma once
// Particles of a decomposed DemSystem across ranks (dem/README.md, "Many
// ranks"): migration of owned particles to the rank whose piece holds their
// centre and the rebuild of the ghost copies, both at neighbour-list builds;
// the refresh of the ghosts' positions and predicted velocities before every
// force evaluation in between.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "core/buffer.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "dem/domain.hpp"
#include "dem/geometry.hpp"
#include "dem/system.hpp"
#include "halo/transport.hpp"
#include "particle_store.hpp"

namespace lbdem::dem {

// Plain records packed into byte messages (particle migration, checkpoint
// sections): append_pod writes one, take_pod reads the next one at `at`
// (Error when the message ends first).
template <class T>
void append_pod(std::vector<std::byte>& b, const T& v) {
  const std::size_t at = b.size();
  b.resize(at + sizeof(T));
  std::memcpy(b.data() + at, &v, sizeof(T));
}
template <class T>
T take_pod(const std::vector<std::byte>& b, std::size_t& at) {
  if (at + sizeof(T) > b.size()) throw Error("DEM: a particle message or record cut short");
  T v;
  std::memcpy(&v, b.data() + at, sizeof(T));
  at += sizeof(T);
  return v;
}
// One row entry of the neighbour list by partner: its global id and the
// tangential history of the contact.
struct RowEntry {
  std::int64_t gid;
  Vec3d h;
};

class DomainExchange {
 public:
  // Checks every piece against the ghost width `width` [m] (ConfigError: a
  // thinner piece would need ghosts from beyond its neighbours) and finds
  // the neighbour ranks (the pieces around this one, across periodic faces
  // too; each rank once).
  // `coupling`: the store carries a coupling input (external force and
  // torque), whose ghost shares return_coupling() sends to the owners.
  void init(const DemDomain& d, const Box& box, double width, const Exec& ex, bool coupling = false);
  // The particles of a whole set whose centre (wrapped into the box) lies in
  // this rank's piece.
  HostParticles select_owned(const HostParticles& hp) const;
  // At a list build, before the cell sort: the owned particles that left the
  // piece go to their new owner with their whole state, wall histories and
  // list row (partner ids and tangential histories); the ghosts are rebuilt
  // from the owned particles within the ghost width of each neighbour's
  // piece. Host-staged through Comm::exchange. Fills the store (owned first,
  // then ghosts) and the previous list the build looks histories up in.
  void redistribute(DemSystem::Impl& m);
  // After the build (the store is in cell order): the index lists of the
  // per-step ghost refresh, and the transport's messages.
  void bind_refresh(DemSystem::Impl& m);
  // Positions and predicted velocities (and angular velocities) of the owned
  // particles to their ghost copies (pack kernel, transport, unpack kernel).
  void refresh(DemSystem::Impl& m);
  // Current positions, velocities and angular velocities of the owned
  // particles to their ghost copies (the synchronised state a coupling reads
  // between advance() calls; refresh() carries predicted velocities).
  void sync_state(DemSystem::Impl& m);
  // The coupling input a rank accumulated on its ghosts back to the owners,
  // each owner adding the shares to its own value peer by peer in ascending
  // peer rank (a fixed order for a given decomposition).
  void return_coupling(DemSystem::Impl& m);
  // Checkpoint state (dem/src/system_state.cpp): the ghost bookkeeping of the
  // last build (bind_refresh() then rebinds the refresh from it).
  void save_state(ckpt::Sink& out) const;
  void load_state(ckpt::Source& in);

  DemDomain dom;
  long migrations[3] = {0, 0, 0};  // sent across a face, an edge, a corner (DemStats)
  long migrations_periodic = 0;

 private:
  bool near_piece(const Vec3d& x, std::size_t k) const;

  Exec ex;
  Box box;
  double width = 0;
  std::vector<int> peers;             // neighbour ranks, ascending
  std::vector<Vec3d> peer_lo, peer_hi;  // their pieces
  // Global ids of the ghosts sent to / received from each peer, ascending
  // (the order of the refresh messages).
  std::vector<std::vector<std::int64_t>> sent, received;
  Buffer<int> send_idx, recv_idx;  // store index per refresh record
  Buffer<Real4> send_buf, recv_buf;
  Index nsend = 0, nrecv = 0;
  int per = 2;  // Real4 per refresh record: position, predicted velocity (+ angular velocity)
  std::unique_ptr<halo::Transport> transport;
  bool messages = false;
  // Coupling return (the refresh messages reversed): per peer, the records
  // [soff[k], soff[k + 1]) of send_idx and [roff[k], roff[k + 1]) of recv_idx.
  std::vector<std::size_t> soff, roff;
  Buffer<Real4> back_send, back_recv;  // force, torque per ghost / per owned record
  std::unique_ptr<halo::Transport> back;
};

}  // namespace lbdem::dem
