// The many-GPU model: its halo bytes are those the fluid halo packs, one rank
// is perfectly efficient, more latency or less bandwidth never speeds a step
// up, and the calibration reproduces its calibration points within 10 %.
#include <gtest/gtest.h>

#include <map>

#include "halo/decomposition.hpp"
#include "lbm/halo_exchange.hpp"
#include "model.hpp"

using namespace lbdem;
using namespace lbdem::scaling_model;

namespace {

Model base_model() {
  Model m;
  // H100, D3Q19 A-A at 256^3 (lbm_h100.json): the rate is flat above it.
  m.rates.add(false, 256.0 * 256 * 256, 18186e6);
  m.rates.add(false, 512.0 * 512 * 512, 18231e6);
  m.rates.add(true, 256.0 * 256 * 256, 9515e6);
  m.rates.add(true, 512.0 * 512 * 512, 9511e6);
  m.machine.copy_Bps.value = 3.0e12;
  m.suspension.psm_s_per_cell_fp32.value = 1.6e-11;
  m.suspension.psm_s_per_cell_fp64.value = 2.1e-11;
  return m;
}

// The H100 points of lbdem_bench_scaling (commit a673d61): one rank, and two
// ranks sharing the GPU over host-staged MPI.
std::vector<Measured> h100_points() {
  struct P {
    int ranks;
    const char* mode;
    long nz;
    bool fp64;
    double step, compute, serial, exposed, comm;
    long bytes;
  };
  const P ps[] = {
      {1, "strong", 256, false, 9.220544e-04, 9.220544e-04, 9.220544e-04, 0, 0, 0},
      {2, "strong", 256, false, 1.555555e-03, 1.114080e-03, 1.998878e-03, 4.414753e-04, 8.847979e-04, 2621440},
      {2, "weak", 512, false, 2.450331e-03, 2.195828e-03, 3.007973e-03, 2.545031e-04, 8.121454e-04, 2621440},
      {1, "strong", 256, true, 1.760834e-03, 1.760834e-03, 1.760834e-03, 0, 0, 0},
      {2, "strong", 256, true, 2.480536e-03, 2.061166e-03, 3.442691e-03, 4.193700e-04, 1.381525e-03, 5242880},
      {2, "weak", 512, true, 4.155468e-03, 4.086908e-03, 5.201292e-03, 6.856058e-05, 1.114384e-03, 5242880},
  };
  std::vector<Measured> out;
  for (const P& p : ps) {
    Measured m;
    m.device = "NVIDIA H100 80GB HBM3";
    m.transport = p.ranks > 1 ? "host_mpi" : "none";
    m.mode = p.mode;
    m.ranks = p.ranks;
    m.ranks_per_gpu = p.ranks;
    m.dims = p.ranks > 1 ? std::array<int, 3>{1, 1, 2} : std::array<int, 3>{1, 1, 1};
    m.grid = {256, 256, p.nz};
    m.fp64 = p.fp64;
    m.t_step = p.step;
    m.t_compute = p.compute;
    m.t_serial = p.serial;
    m.exposed = p.exposed;
    m.comm = p.comm;
    m.halo_bytes = p.bytes;
    m.messages = p.ranks > 1 ? 2 : 0;
    out.push_back(m);
  }
  return out;
}

}  // namespace

TEST(ScalingModel, HaloBytesEqualWhatTheFluidHaloPacks) {
  struct D {
    std::array<long, 3> grid;
    int ranks;
    std::array<int, 3> dims;
    std::array<bool, 3> periodic;
  };
  const D cases[] = {
      {{16, 16, 16}, 2, {1, 1, 2}, {true, true, true}},
      {{16, 12, 10}, 4, {2, 2, 1}, {true, true, true}},
      {{12, 12, 12}, 8, {2, 2, 2}, {true, true, true}},
      {{30, 20, 17}, 12, {3, 2, 2}, {true, false, true}},  // uneven, one walled axis
      {{9, 11, 13}, 27, {3, 3, 3}, {false, true, false}},
      {{40, 8, 8}, 5, {5, 1, 1}, {true, true, true}},
  };
  for (const D& d : cases) {
    const Grid whole = Grid::whole(d.grid, d.periodic);
    const halo::Decomposition dec = halo::decompose(whole, d.ranks, d.dims);
    for (const int tb : {4, 8}) {
      for (int r = 0; r < dec.ranks(); ++r) {
        const Grid piece = dec.piece(whole, r);
        const auto code = lbm::halo_links(dec, r, piece, lbm::LatticeKind::D3Q19);
        const auto model = fluid_links(dec, r, tb, 8);
        ASSERT_EQ(code.size(), model.size()) << dec.describe() << " rank " << r;
        std::map<int, long> want;  // by direction index
        for (const auto& k : code) {
          const long b = static_cast<long>(k.send_fill_tl.bytes(tb));
          // Every phase sends the same number of bytes per link.
          EXPECT_EQ(b, static_cast<long>(k.send_fill_aa.bytes(tb)));
          EXPECT_EQ(b, static_cast<long>(k.send_back.bytes(tb)));
          want[k.tag] = b;
        }
        for (const auto& k : model) {
          const int tag = (k.dir[0] + 1) + 3 * (k.dir[1] + 1) + 9 * (k.dir[2] + 1);
          ASSERT_TRUE(want.count(tag)) << dec.describe() << " rank " << r << " tag " << tag;
          EXPECT_EQ(want[tag], k.bytes) << dec.describe() << " rank " << r << " tag " << tag;
        }
        for (const auto& k : code) {
          bool found = false;
          for (const auto& q : model) found = found || (q.peer == k.peer && q.dir == k.dir);
          EXPECT_TRUE(found) << dec.describe() << " rank " << r << " peer " << k.peer;
        }
      }
    }
  }
}

TEST(ScalingModel, FaceAndEdgeBytes) {
  // 2 x 2 x 1 on 16 x 12 x 10: per rank 8 x 6 x 10; faces: 5 slots x 6 x 10
  // (x) and 5 x 8 x 10 (y), twice each; edges 1 slot x 10 cells, four.
  const halo::Decomposition dec = halo::decompose(Grid::whole({16, 12, 10}), 4, {2, 2, 1});
  long total = 0;
  for (const auto& k : fluid_links(dec, 0, 4, 8)) total += k.bytes;
  EXPECT_EQ(total, 4L * (2 * 5 * 6 * 10 + 2 * 5 * 8 * 10 + 4 * 10));
}

TEST(ScalingModel, OneRankIsPerfectlyEfficient) {
  const Model m = base_model();
  Case c;
  c.grid = {256, 256, 256};
  const Prediction p = m.predict(c);
  EXPECT_DOUBLE_EQ(p.t_step, 256.0 * 256 * 256 / 18186e6);
  EXPECT_EQ(p.t_exposed, 0);
  EXPECT_EQ(p.halo_bytes, 0);
  c.particles = 4101;
  const Prediction q = m.predict(c);
  EXPECT_EQ(q.t_imbalance, 0);
  EXPECT_EQ(q.t_particles, 0);
}

TEST(ScalingModel, MoreLatencyOrLessBandwidthNeverHelps) {
  for (const Transport tp : {Transport::HostMpi, Transport::DeviceMpi, Transport::Nccl}) {
    Case c;
    c.grid = {512, 512, 512};
    c.ranks = 64;
    c.transport = tp;
    Model m = base_model();
    m.machine.overlap_eff.value = 0.3;
    double prev = 0;
    for (const double lat : {1e-6, 1e-5, 1e-4, 1e-3}) {
      m.machine.lat_mpi_s.value = m.machine.lat_ib_s.value = m.machine.lat_nccl_s.value = lat;
      const double t = m.predict(c).t_step;
      EXPECT_GE(t, prev) << to_string(tp) << " latency " << lat;
      prev = t;
    }
    EXPECT_GT(prev, m.predict(c).t_compute + 1e-3) << to_string(tp) << ": 1 ms latency must show";
    m = base_model();
    m.machine.overlap_eff.value = 0.0;
    prev = 0;
    for (const double bw : {400e9, 100e9, 25e9, 5e9}) {
      m.machine.nvlink_Bps.value = m.machine.ib_node_Bps.value = m.machine.host_mpi_Bps.value = bw;
      const double t = m.predict(c).t_step;
      EXPECT_GT(t, prev) << to_string(tp) << " bandwidth " << bw;
      prev = t;
    }
    // A better overlap never costs time; strong-scaling efficiency falls with GPUs.
    m = base_model();
    double prev_t = 1e9;
    for (const double eta : {0.0, 0.5, 1.0}) {
      m.machine.overlap_eff.value = eta;
      const double t = m.predict(c).t_step;
      EXPECT_LE(t, prev_t);
      prev_t = t;
    }
  }
  Model m = base_model();
  double prev_eff = 1.01;
  Case c;
  c.grid = {1024, 1024, 1024};
  c.transport = Transport::Nccl;
  c.ranks = 1;
  const double t1 = m.predict(c).t_step;
  for (const int n : {8, 64, 512, 4096}) {
    c.ranks = n;
    const double eff = t1 / (n * m.predict(c).t_step);
    EXPECT_LT(eff, prev_eff) << n;
    prev_eff = eff;
  }
  // More clustering, more time.
  c.ranks = 64;
  c.particles = 100000;
  m.suspension.clustering.value = 1.0;
  const double t_even = m.predict(c).t_step;
  m.suspension.clustering.value = 2.0;
  EXPECT_GT(m.predict(c).t_step, t_even);
}

TEST(ScalingModel, CalibrationReproducesItsPoints) {
  Model m;
  const auto pts = h100_points();
  m.machine.copy_Bps.value = 2.99e12;
  const auto log = calibrate(m, pts);
  EXPECT_GE(log.size(), 3u);
  EXPECT_EQ(m.machine.overlap_eff.source, Source::Fitted);
  EXPECT_GT(m.machine.overlap_eff.value, 0);
  for (const Measured& p : pts) {
    const Prediction q = m.predict(case_of(p));
    EXPECT_NEAR(q.t_step / p.t_step, 1.0, 0.10) << p.mode << (p.fp64 ? " fp64 " : " fp32 ") << p.ranks << " ranks";
    if (p.ranks > 1) {
      EXPECT_EQ(q.halo_bytes, p.halo_bytes);
    }
  }
}

TEST(ScalingModel, RefusesUnknownTransport) {
  EXPECT_THROW(parse_transport("infiniband", "transport"), std::invalid_argument);
  EXPECT_EQ(parse_transport("nccl", "transport"), Transport::Nccl);
}
