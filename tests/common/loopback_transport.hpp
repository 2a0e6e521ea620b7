#pragma once
// Several ranks in one process: a halo::Transport whose messages go through a
// shared mailbox. Every rank's start() must run before any rank's finish()
// (FluidHalo::begin_step for all ranks, then finish_step for all).
#include <cstring>
#include <map>
#include <tuple>
#include <vector>

#include "core/buffer.hpp"
#include "halo/transport.hpp"

namespace lbdem::test {

struct Mailbox {
  std::map<std::tuple<int, int, int>, std::vector<std::byte>> box;  // (from, to, tag) -> bytes
};

class LoopbackTransport final : public halo::Transport {
 public:
  LoopbackTransport(Mailbox& mail, int rank, Backend b) : mail_(mail), rank_(rank), b_(b) {}
  void bind(std::vector<halo::Message> m) override { msgs_ = std::move(m); }
  void start(const Exec& ex) override {
    ex.synchronize();
    for (const auto& m : msgs_) {
      auto& v = mail_.box[{rank_, m.peer, m.tag}];
      v.resize(m.send_bytes);
      if (m.send_bytes) backend_copy_to_host(b_, v.data(), m.send, m.send_bytes);
    }
  }
  void finish(const Exec&) override {
    for (const auto& m : msgs_) {
      auto it = mail_.box.find({m.peer, rank_, m.recv_tag});
      if (it == mail_.box.end() || it->second.size() != m.recv_bytes) throw Error("loopback: message missing or of wrong size");
      if (m.recv_bytes) backend_copy_from_host(b_, m.recv, it->second.data(), m.recv_bytes);
    }
  }
  halo::TransportKind kind() const override { return halo::TransportKind::HostMpi; }
  const halo::TransportTimes& times() const override { return t_; }

 private:
  Mailbox& mail_;
  int rank_;
  Backend b_;
  std::vector<halo::Message> msgs_;
  halo::TransportTimes t_;
};

}  // namespace lbdem::test
