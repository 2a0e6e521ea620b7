// LbmSolver::save_state / load_state through a checkpoint file
// (core/checkpoint.hpp), every lattice, precision and streaming scheme:
// N steps straight equal k steps + save + a fresh solver loaded + N - k,
// bit for bit, with k odd (A-A: the populations stored in the other parity);
// a state of another precision, lattice, scheme or grid is refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <string>

#include "common/backends.hpp"
#include "core/checkpoint.hpp"
#include "core/error.hpp"
#include "lbm_test_util.hpp"

namespace lbdem::test {
namespace {

namespace fs = std::filesystem;

struct StateCase {
  Backend backend;
  lbm::LatticeKind lattice;
  lbm::Precision precision;
  lbm::StreamKind streaming;
};

Scene channel(const StateCase& c) {
  const bool d3 = c.lattice == lbm::LatticeKind::D3Q19;
  Scene s = make_scene(c.lattice, 12, 10, d3 ? 6 : 1);
  s.setup.precision = c.precision;
  s.setup.streaming = c.streaming;
  s.setup.tau = 0.7;
  s.setup.domain.periodic = {true, false, true};
  s.setup.body_force = {1e-5, 0, 0};
  const int wall = add_boundary(s, lbm::BoundaryKind::Wall);
  add_y_walls(s, wall, wall);
  randomize(s, 1e-3, 1e-2, 11);
  return s;
}

std::string temp_file(const std::string& tag) {
  return (fs::temp_directory_path() / ("lbdem_lbm_state_" + std::to_string(::getpid()) + "_" + tag)).string();
}

void save(lbm::LbmSolver& f, const std::string& path) {
  ckpt::Writer w(path, {}, f.steps_done(), 0.0);
  w.section("lbm");
  f.save_state(w);
  w.commit();
}

void load(lbm::LbmSolver& f, const std::string& path) {
  ckpt::Reader r(path);
  r.section("lbm");
  f.load_state(r);
  r.finish();
}

class LbmState : public ::testing::TestWithParam<StateCase> {};

TEST_P(LbmState, StraightEqualsSaveLoadContinueBitwise) {
  const StateCase c = GetParam();
  const Scene s = channel(c);
  const long N = 20, k = 7;
  auto straight = lbm::make_lbm_solver(s.setup, c.backend);
  straight->initialize(s.flags, s.rho, s.u);
  straight->step(N);
  auto first = lbm::make_lbm_solver(s.setup, c.backend);
  first->initialize(s.flags, s.rho, s.u);
  first->step(k);
  const std::string path = temp_file("run");
  save(*first, path);
  auto second = lbm::make_lbm_solver(s.setup, c.backend);
  second->initialize(s.flags, std::vector<double>(s.rho.size(), 1.0), std::vector<double>(s.u.size(), 0.0));
  load(*second, path);
  fs::remove(path);
  EXPECT_EQ(second->steps_done(), k);
  const auto pa = first->populations(), pb = second->populations();
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(0, std::memcmp(pa.data(), pb.data(), pa.size() * sizeof(double))) << "state after loading";
  second->step(N - k);
  const auto ps = straight->populations(), pc = second->populations();
  ASSERT_EQ(ps.size(), pc.size());
  EXPECT_EQ(0, std::memcmp(ps.data(), pc.data(), ps.size() * sizeof(double))) << "state after continuing";
  EXPECT_EQ(second->steps_done(), N);
}

TEST_P(LbmState, OtherPrecisionSchemeOrGridIsRefused) {
  const StateCase c = GetParam();
  const Scene s = channel(c);
  auto f = lbm::make_lbm_solver(s.setup, c.backend);
  f->initialize(s.flags, s.rho, s.u);
  f->step(3);
  const std::string path = temp_file("refuse");
  save(*f, path);
  auto refused = [&](lbm::LbmSetup other, const Scene& sc, const char* what) {
    auto g = lbm::make_lbm_solver(other, c.backend);
    g->initialize(sc.flags, sc.rho, sc.u);
    try {
      load(*g, path);
      ADD_FAILURE() << "loaded into a solver of another " << what;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  lbm::LbmSetup o = s.setup;
  o.precision = c.precision == lbm::Precision::FP32 ? lbm::Precision::FP64 : lbm::Precision::FP32;
  refused(o, s, "precision");
  o = s.setup;
  o.streaming = c.streaming == lbm::StreamKind::AA ? lbm::StreamKind::TwoLattice : lbm::StreamKind::AA;
  refused(o, s, "streaming");
  Scene sb = make_scene(c.lattice, 14, 10, c.lattice == lbm::LatticeKind::D3Q19 ? 6 : 1);
  sb.setup.precision = c.precision;
  sb.setup.streaming = c.streaming;
  refused(sb.setup, sb, "cell count");
  fs::remove(path);
}

std::vector<StateCase> state_cases() {
  std::vector<StateCase> v;
  for (Backend b : backends())
    for (auto l : {lbm::LatticeKind::D2Q9, lbm::LatticeKind::D3Q19})
      for (auto p : {lbm::Precision::FP32, lbm::Precision::FP64})
        for (auto st : {lbm::StreamKind::AA, lbm::StreamKind::TwoLattice}) v.push_back({b, l, p, st});
  return v;
}

INSTANTIATE_TEST_SUITE_P(All, LbmState, ::testing::ValuesIn(state_cases()), [](const auto& info) {
  const StateCase& c = info.param;
  return std::string(to_string(c.backend)) + "_" + lbm::to_string(c.lattice) + "_" + lbm::to_string(c.precision) +
         "_" + (c.streaming == lbm::StreamKind::AA ? "aa" : "two_lattice");
});

}  // namespace
}  // namespace lbdem::test
