// The one time loop (halo/simulation.hpp): where it stops, which operations
// run at which step and in which order, a stop signal, a restart's cadence and
// the summary it writes.
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "halo/simulation.hpp"
#include "core/signals.hpp"

using namespace lbdem;
using sim::Event;
using sim::Simulation;
using sim::Trigger;

namespace {
const halo::Comm& one() { return halo::Comm::world(); }

// A log of (operation, step) in the order they ran.
struct Log {
  std::vector<std::pair<std::string, long>> runs;
  sim::Simulation::Op op(const std::string& name) {
    return [this, name](const Event& e) { runs.emplace_back(name, e.step); };
  }
  std::vector<long> steps_of(const std::string& name) const {
    std::vector<long> s;
    for (auto& [n, st] : runs)
      if (n == name) s.push_back(st);
    return s;
  }
};
}  // namespace

TEST(Simulation, StopsAtEveryAlignedMultipleAndTheEnd) {
  // Fixed chunks of 8: calls end at multiples of 3, 5, 8 and at 20; the
  // unaligned every-4 operation runs only where a stop falls on a multiple of 4.
  Simulation s(one(), "t", 0, 20, sim::Stepping{.chunk = 8});
  Log log;
  s.add("a", Trigger::steps(3), log.op("a"));
  s.add("b", Trigger::steps(5), log.op("b"));
  s.add("c", Trigger{.every_steps = 4, .aligned = false}, log.op("c"));
  std::vector<long> calls;
  long done = 0;
  EXPECT_TRUE(s.run([&](long n) {
    done += n;
    calls.push_back(done);
  }));
  EXPECT_EQ(calls, (std::vector<long>{3, 5, 6, 8, 9, 10, 12, 15, 16, 18, 20}));
  EXPECT_EQ(log.steps_of("a"), (std::vector<long>{3, 6, 9, 12, 15, 18}));
  EXPECT_EQ(log.steps_of("b"), (std::vector<long>{5, 10, 15, 20}));
  EXPECT_EQ(log.steps_of("c"), (std::vector<long>{8, 12, 16, 20}));
  EXPECT_EQ(s.step(), 20);
  EXPECT_FALSE(s.interrupted());
}

TEST(Simulation, AdaptiveOnOneRankStepsOneAtATime) {
  // One rank looks at its stop flag after every step; operations still run
  // only at their boundaries.
  Simulation s(one(), "t", 0, 7);
  Log log;
  s.add("a", Trigger::steps_and_end(3), log.op("a"));
  long calls = 0, done = 0;
  s.run([&](long n) {
    ++calls;
    done += n;
  });
  EXPECT_EQ(calls, 7);
  EXPECT_EQ(done, 7);
  EXPECT_EQ(log.steps_of("a"), (std::vector<long>{3, 6, 7}));
}

TEST(Simulation, AnOperationEndsTheRunEarly) {
  // A steady state reached at step 30: no step after it, the operations
  // added after the one that ends the run still run there, and the run counts
  // as done, not interrupted.
  Simulation s(one(), "t", 0, 100, sim::Stepping{.chunk = 10});
  Log log;
  s.add("a", Trigger::steps(10), [&](const Event& e) {
    log.runs.emplace_back("a", e.step);
    if (e.step == 30) s.end_here();
  });
  s.add("b", Trigger::steps(10), log.op("b"));
  long done = 0;
  EXPECT_TRUE(s.run([&](long n) { done += n; }));
  EXPECT_EQ(done, 30);
  EXPECT_EQ(s.step(), 30);
  EXPECT_FALSE(s.interrupted());
  EXPECT_TRUE(s.ended_early());
  EXPECT_EQ(log.steps_of("a"), (std::vector<long>{10, 20, 30}));
  EXPECT_EQ(log.steps_of("b"), (std::vector<long>{10, 20, 30}));
}

TEST(Simulation, StartEndAndOrderOnceAStep) {
  Simulation s(one(), "t", 0, 10, sim::Stepping{.chunk = 64});
  Log log;
  s.add("series", Trigger::steps_and_end(4), log.op("series"));
  s.add("snapshot", Trigger{.every_steps = 5, .at_start = true, .at_end = true}, log.op("snapshot"));
  s.add("checkpoint", Trigger{.every_steps = 4, .at_finish = true, .aligned = false}, log.op("checkpoint"));
  s.run([](long) {});
  // Registration order within a step; step 10 is a multiple of 5 and the
  // end: the snapshot runs there once.
  const std::vector<std::pair<std::string, long>> want{
      {"snapshot", 0}, {"series", 4},     {"checkpoint", 4}, {"snapshot", 5},
      {"series", 8},   {"checkpoint", 8}, {"series", 10},    {"snapshot", 10}, {"checkpoint", 10}};
  EXPECT_EQ(log.runs, want);
}

TEST(Simulation, StopSignalEndsAtTheNextCheckWithFinalOperations) {
  install_stop_handlers();
  clear_stop_request();
  Simulation s(one(), "t", 0, 1000, sim::Stepping{.chunk = 16});
  Log log;
  std::vector<Event> ends;
  s.add("series", Trigger::steps_and_end(100), log.op("series"));
  s.add("checkpoint", Trigger{.every_steps = 500, .at_stop = true, .at_finish = true, .aligned = false},
        [&](const Event& e) { ends.push_back(e); });
  s.add("snapshot", Trigger{.every_steps = 250, .at_end = true}, log.op("snapshot"));
  long done = 0;
  bool raised = false;
  const bool finished = s.run([&](long n) {
    done += n;
    if (done >= 40 && !raised) {  // a signal during the chunk 32..48
      std::raise(SIGTERM);
      raised = true;
    }
  });
  clear_stop_request();
  EXPECT_FALSE(finished);
  EXPECT_TRUE(s.interrupted());
  EXPECT_EQ(s.step(), 48);  // the chunk in progress (32..48) finishes
  EXPECT_EQ(log.steps_of("series"), (std::vector<long>{48}));
  EXPECT_EQ(log.steps_of("snapshot"), (std::vector<long>{48}));
  ASSERT_EQ(ends.size(), 1u);
  EXPECT_TRUE(ends[0].stopping);
  EXPECT_TRUE(ends[0].last);
  EXPECT_FALSE(ends[0].finished);
}

TEST(Simulation, AdaptiveStopOnOneRankAfterTheStep) {
  install_stop_handlers();
  clear_stop_request();
  Simulation s(one(), "t", 0, 100);
  Log log;
  s.add("end", Trigger{.at_end = true}, log.op("end"));
  long done = 0;
  s.run([&](long n) {
    done += n;
    if (done == 13) std::raise(SIGINT);
  });
  clear_stop_request();
  EXPECT_EQ(s.step(), 13);
  EXPECT_EQ(log.steps_of("end"), (std::vector<long>{13}));
}

TEST(Simulation, RestartResumesTheCadence) {
  // A straight run of 30 steps against one stopped at a checkpoint of step 12
  // and restarted: the restarted part calls and runs its operations at the
  // same steps as the straight run does after 12, and none again at 12.
  auto record = [](long first, long last, std::vector<long>& calls, Log& log) {
    Simulation s(one(), "t", first, last, sim::Stepping{.chunk = 7});
    s.add("series", Trigger::steps_and_end(4), log.op("series"));
    s.add("snapshot", Trigger{.every_steps = 10, .at_start = true, .at_end = true}, log.op("snapshot"));
    long done = first;
    s.run([&](long n) {
      done += n;
      calls.push_back(done);
    });
  };
  std::vector<long> straight, restarted;
  Log a, b;
  record(0, 30, straight, a);
  record(12, 30, restarted, b);
  std::vector<long> tail;
  for (long c : straight)
    if (c > 12) tail.push_back(c);
  EXPECT_EQ(restarted, tail);
  std::vector<std::pair<std::string, long>> want;
  for (auto& r : a.runs)
    if (r.second > 12) want.push_back(r);
  EXPECT_EQ(b.runs, want);
  // A restart at its last step runs nothing.
  Log c;
  std::vector<long> none;
  record(30, 30, none, c);
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(c.runs.empty());
}

TEST(Simulation, WallTimeTrigger) {
  Simulation s(one(), "t", 0, 6, sim::Stepping{.chunk = 1});
  Log log;
  s.add("slow", Trigger{.every_seconds = 1e9}, log.op("slow"));
  s.add("fast", Trigger{.every_seconds = 1e-12}, log.op("fast"));
  s.run([](long) {});
  EXPECT_TRUE(log.steps_of("slow").empty());
  EXPECT_EQ(log.steps_of("fast"), (std::vector<long>{1, 2, 3, 4, 5, 6}));
}

TEST(Simulation, SummaryHasLoopAndSceneFields) {
  const auto dir = std::filesystem::temp_directory_path() / "lbdem_sim_summary";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  Simulation s(one(), "demo", 0, 5, sim::Stepping{.chunk = 5}, "fluid");
  s.add("out", Trigger::steps(5), [](const Event&) {}, true);
  s.run([](long) {});
  s.summary()["verification"]["error"] = 2.5e-7;
  s.summary()["steps_planned"] = 5;
  s.write_summary(dir.string());
  std::ifstream in(dir / "summary.json");
  std::stringstream text;
  text << in.rdbuf();
  const json::Value v = json::Value::parse(text.str());
  EXPECT_EQ(v.at("scene").as_string(), "demo");
  EXPECT_EQ(v.at("steps").as_integer(), 5);
  EXPECT_FALSE(v.at("interrupted").as_bool());
  EXPECT_EQ(v.at("ranks").as_integer(), 1);
  EXPECT_TRUE(v.at("phases_s").has("fluid"));
  EXPECT_TRUE(v.at("phases_s").has("out"));
  EXPECT_EQ(v.at("verification").at("error").as_number(), 2.5e-7);
  std::filesystem::remove_all(dir);
}
