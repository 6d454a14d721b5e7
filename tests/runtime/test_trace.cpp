// Tracing a running runtime (docs/runtime.md, "Tracing a running runtime"):
// the task records every cycle once with the values its program used, a
// reader that stalls gets an exact lost count, the selection is refused
// clearly when it cannot be sampled and ends when its lease runs out; and
// `rtplc trace` against a real `rtplc run`: CSV in sim's layout, trigger,
// a stalled tool reporting what it lost, clear errors.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <thread>

#include "io/process_image.h"
#include "io/trace_ring.h"
#include "tests/support/run_tool.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;
using rtplc::test::run_shell;
using rtplc::test::run_tool;

// A ramp: Ramp grows by Rate * dt every cycle (intg, backward Euler), so
// after cycle c (counted from 0) it is (c + 1) * 0.001 at 1 ms and Rate 1.
// PVcopy is the plant measurement PV as the program read it in that cycle.
const char* kRamp =
    "%%\nF1 = asp(d0, c0, 1, \"Rate\")\nF2 = intg(F1, 1)\ndao(F2, p0, d0, c0, \"Ramp\")\n"
    "F3 = dai(p0, d0, c0, \"PV\")\ndao(F3, p0, d0, c1, \"PVcopy\")\nEND\n";
const char* kOther = "%%\nF1 = asp(d0, c1, 2, \"Gain\")\ndao(F1, p0, d0, c2, \"Other\")\nEND\n";
const char* kConfig =
    "tasks:\n"
    "  - {name: ramp, program: ramp.fbd, period: 1ms}\n"
    "  - {name: other, program: other.fbd, period: 10ms}\n"
    "drivers:\n"
    "  - kind: sim\n"
    "    period: 1ms\n"
    "    plants: [{model: second-order, input: p0.d0.c0, output: p0.d0.c0}]\n";
constexpr double kDt = 0.001;

struct Started {
  std::string token;
  uint32_t task = 0;
  uint64_t first = 0;
};

Started parse(const std::string& body) {
  Started s;
  std::istringstream in(body);
  std::string w, name;
  int64_t period = 0;
  in >> w >> s.token >> w >> name >> s.task >> period >> s.first;
  return s;
}

std::unique_ptr<Runtime> start(RuntimeFixture& fx) {
  fx.write("ramp.fbd", kRamp);
  fx.write("other.fbd", kOther);
  RuntimeOptions opt;
  opt.lock_memory = false;
  return fx.start(kConfig, opt);
}

// Drains until `want` samples arrived (bounded by count, not time).
void drain_until(io::TraceReader& r, std::vector<io::TraceSample>& got, size_t want) {
  for (int i = 0; i < 20000 && got.size() < want; ++i) {
    r.drain(got);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

TEST(Trace, every_cycle_of_an_integrator_is_recorded_once_with_the_values_its_program_used) {
  RuntimeFixture fx;
  auto rt = start(fx);
  ASSERT_NE(rt, nullptr);
  auto body = rt->trace_start({"Ramp", "Rate", "PV", "PVcopy"});
  ASSERT_TRUE(body.ok()) << body.error();
  const Started st = parse(*body);
  EXPECT_EQ(st.task, 0u);
  EXPECT_NE(body->find("column PV input analog"), std::string::npos) << *body;
  EXPECT_NE(body->find("column Rate setpoint analog"), std::string::npos) << *body;
  io::TraceReader r(rt->image().trace_block(st.task), st.first, 4);
  std::vector<io::TraceSample> got;
  drain_until(r, got, 1500);
  ASSERT_GE(got.size(), 1500u);
  EXPECT_EQ(r.lost(), 0u) << "a reader draining every 5 ms keeps up with a 2048-record ring at 1 ms";
  size_t bad_step = 0, bad_value = 0, bad_pv = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const io::TraceSample& s = got[i];
    ASSERT_EQ(s.record, st.first + i) << "every record once, in order";
    if (i > 0) {
      ASSERT_EQ(s.cycle, got[i - 1].cycle + 1) << "every cycle once";
      // On the 1 ms grid (a cycle that overran on this shared machine skips releases).
      EXPECT_GE(s.release_ns - got[i - 1].release_ns, 1000000);
      EXPECT_EQ((s.release_ns - got[i - 1].release_ns) % 1000000, 0);
      bad_step += std::abs(s.values[0] - got[i - 1].values[0] - kDt) > 1e-9;
    }
    bad_value += std::abs(s.values[0] - static_cast<double>(s.cycle + 1) * kDt) > 1e-9 * static_cast<double>(s.cycle + 1);
    EXPECT_EQ(s.values[1], 1.0);
    bad_pv += s.values[2] != s.values[3];
  }
  EXPECT_EQ(bad_step, 0u) << "the integrator grows by Rate * dt per cycle";
  EXPECT_EQ(bad_value, 0u) << "Ramp = (cycle + 1) * dt";
  EXPECT_EQ(bad_pv, 0u) << "an input is recorded as the program read it in that cycle";

  // Ended: the task stops appending.
  ASSERT_TRUE(rt->trace_end(st.token).ok());
  const io::TraceBlock* b = rt->image().trace_block(st.task);
  for (int i = 0; i < 1000 && !io::trace_applied(*b); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_TRUE(io::trace_applied(*b));
  const uint64_t h1 = b->ring.head.load();
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  EXPECT_EQ(b->ring.head.load(), h1);
  rt->stop();
}

TEST(Trace, a_swap_moves_the_trace_to_the_new_program_without_losing_a_cycle) {
  RuntimeFixture fx;
  auto rt = start(fx);
  ASSERT_NE(rt, nullptr);
  auto body = rt->trace_start({"Ramp", "PV"});
  ASSERT_TRUE(body.ok()) << body.error();
  const Started st = parse(*body);
  io::TraceReader r(rt->image().trace_block(st.task), st.first, 2);
  std::vector<io::TraceSample> got;
  drain_until(r, got, 200);
  // The new program keeps the integrator (same block) and no longer reads PV.
  const std::string next = "%%\nF1 = asp(d0, c0, 1, \"Rate\")\nF2 = intg(F1, 1)\ndao(F2, p0, d0, c0, \"Ramp\")\nEND\n";
  auto sw = rt->swap("ramp", next, "next.fbd", {"PVcopy"});
  ASSERT_TRUE(sw.ok()) << sw.error();
  const size_t at_swap = got.size();
  drain_until(r, got, at_swap + 300);
  EXPECT_EQ(r.lost(), 0u);
  size_t nan_pv = 0, gaps = 0, bad_step = 0;
  for (size_t i = 1; i < got.size(); ++i) {
    gaps += got[i].cycle != got[i - 1].cycle + 1;
    bad_step += std::abs(got[i].values[0] - got[i - 1].values[0] - kDt) > 1e-9;
    nan_pv += std::isnan(got[i].values[1]);
  }
  EXPECT_EQ(gaps, 0u) << "every cycle across the swap";
  EXPECT_EQ(bad_step, 0u) << "the integrator's state was kept and traced on";
  EXPECT_GE(nan_pv, 200u) << "a channel the new program does not read is recorded as nan";
  EXPECT_FALSE(std::isnan(got.front().values[1]));
  ASSERT_TRUE(rt->trace_end(st.token).ok());
  rt->stop();
}

TEST(Trace, a_reader_that_stalls_gets_an_exact_lost_count_and_only_intact_records) {
  RuntimeFixture fx;
  auto rt = start(fx);
  ASSERT_NE(rt, nullptr);
  auto body = rt->trace_start({"Ramp"});
  ASSERT_TRUE(body.ok()) << body.error();
  const Started st = parse(*body);
  const io::TraceBlock* b = rt->image().trace_block(st.task);
  // Stall past one lap of the ring (counted in records, not in time).
  for (int i = 0; i < 20000 && b->ring.head.load() < st.first + io::kTraceSlots + 500; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GE(b->ring.head.load(), st.first + io::kTraceSlots + 500);
  io::TraceReader r(b, st.first, 1);
  std::vector<io::TraceSample> got;
  r.drain(got);
  EXPECT_GE(r.lost(), 500u);
  EXPECT_EQ(got.size() + r.lost(), r.next_record() - st.first) << "every record delivered or counted";
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_NEAR(got[i].values[0], static_cast<double>(got[i].cycle + 1) * kDt, 1e-9 * static_cast<double>(got[i].cycle + 1));
    if (i > 0) {
      EXPECT_EQ(got[i].cycle - got[i - 1].cycle, got[i].record - got[i - 1].record);
    }
  }
  ASSERT_TRUE(rt->trace_end(st.token).ok());
  rt->stop();
}

TEST(Trace, what_cannot_be_sampled_is_refused_clearly_and_one_trace_holds_a_task) {
  RuntimeFixture fx;
  auto rt = start(fx);
  ASSERT_NE(rt, nullptr);
  auto r = rt->trace_start({"Rampp"});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("no channel is labelled \"Rampp\" (did you mean \"Ramp\"?)"), std::string::npos) << r.error();
  r = rt->trace_start({"Ramp", "Other"});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("one trace records one task's cycles"), std::string::npos) << r.error();
  r = rt->trace_start({"Ramp", "Ramp"});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("named twice"), std::string::npos) << r.error();
  r = rt->trace_start({"Ramp", "Rate", "PV", "PVcopy", "Ramp1", "Ramp2", "Ramp3", "Ramp4", "Ramp5"});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("at most 8 channels"), std::string::npos) << r.error();

  auto first = rt->trace_start({"Ramp"});
  ASSERT_TRUE(first.ok()) << first.error();
  r = rt->trace_start({"Rate"});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("task ramp is already being traced (Ramp)"), std::string::npos) << r.error();
  auto other = rt->trace_start({"Other", "Gain"});
  EXPECT_TRUE(other.ok()) << "another task's channels trace at the same time";
  ASSERT_TRUE(rt->trace_end(parse(*first).token).ok());
  EXPECT_FALSE(rt->trace_end(parse(*first).token).ok()) << "ended once";
  auto again = rt->trace_start({"Rate"});
  EXPECT_TRUE(again.ok()) << (again.ok() ? "" : again.error());
  rt->stop();
}

TEST(Trace, a_trace_whose_reader_stops_renewing_it_ends) {
  RuntimeFixture fx;
  auto rt = start(fx);
  ASSERT_NE(rt, nullptr);
  auto body = rt->trace_start({"Ramp"});
  ASSERT_TRUE(body.ok()) << body.error();
  const Started st = parse(*body);
  std::string said;
  auto log = [&said](bool, const std::string& l) { said += l + "\n"; };
  ASSERT_TRUE(rt->trace_keep(st.token).ok());
  // The control thread's tick, a few times a second, until the lease ran out.
  for (int i = 0; i < 400 && said.find("stopped renewing") == std::string::npos; ++i) {
    rt->tick(log);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_NE(said.find("trace of task ramp (Ramp) ended: its reader stopped renewing it"), std::string::npos) << said;
  EXPECT_FALSE(rt->trace_keep(st.token).ok());
  const io::TraceBlock* b = rt->image().trace_block(st.task);
  for (int i = 0; i < 1000 && !io::trace_applied(*b); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  EXPECT_TRUE(io::trace_applied(*b));
  EXPECT_EQ(b->control.n, 0u);
  rt->stop();
}

// ---- `rtplc trace` against a real `rtplc run` ----

class TraceTool : public ::testing::Test {
 protected:
  void SetUp() override {
    name_ = "tr" + std::to_string(getpid());
    fx_.write("ramp.fbd", kRamp);
    fx_.write("other.fbd", kOther);
    cfg_ = fx_.write("rt.yaml", "runtime:\n  name: " + name_ + "\n  socket: " + fx_.dir() + "/rt.sock\n"
                                "  retain_file: " + fx_.dir() + "/rt.retain\n  programs: config\n"
                                "  cpu_dma_latency: false\n  lock_memory: false\n" + kConfig);
    const auto r = run_shell(test::rtplc_binary() + " run " + cfg_ + " -q >" + fx_.dir() + "/run.log 2>&1 & echo $!");
    pid_ = std::atoi(r.out.c_str());
    for (int i = 0; i < 300; ++i) {
      if (run_tool("status --name " + name_ + " >/dev/null").status == 0) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    FAIL() << "the runtime did not start: " << run_shell("cat " + fx_.dir() + "/run.log").out;
  }
  void TearDown() override {
    run_tool("stop --name " + name_ + " >/dev/null");
    for (int i = 0; i < 200 && pid_ > 0 && kill(pid_, 0) == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (pid_ > 0 && kill(pid_, 0) == 0) kill(pid_, SIGKILL);
    // A runtime killed with -9 (one test does) leaves its image, as it would in
    // the field; the next start replaces it, but a test leaves nothing behind.
    shm_unlink(io::ProcessImage::shm_name(name_).c_str());
  }
  std::string file(const std::string& n) const { return fx_.dir() + "/" + n; }
  static std::vector<std::string> lines_of(const std::string& path) {
    std::ifstream in(path);
    std::vector<std::string> out;
    for (std::string l; std::getline(in, l);) out.push_back(l);
    return out;
  }
  static std::vector<double> numbers(const std::string& line) {
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) v.push_back(std::stod(f));
    return v;
  }
  RuntimeFixture fx_;
  std::string name_, cfg_;
  int pid_ = -1;
};

TEST_F(TraceTool, writes_every_cycle_in_the_layout_of_sim) {
  const auto r = run_tool("trace Rate Ramp --name " + name_ + " --duration 1 --cycles --csv " + file("t.csv"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find(" samples, 0 lost"), std::string::npos) << r.out;
  const auto lines = lines_of(file("t.csv"));
  ASSERT_GT(lines.size(), 100u);
  EXPECT_EQ(lines[0], "t,cycle,Rate,Ramp");
  size_t rows = 0;
  double first_cycle = -1, last_cycle = -1, last_ramp = 0;
  for (size_t i = 1; i < lines.size(); ++i) {
    if (lines[i][0] == '#') continue;
    const auto v = numbers(lines[i]);
    ASSERT_EQ(v.size(), 4u) << lines[i];
    if (last_cycle >= 0) {
      EXPECT_EQ(v[1], last_cycle + 1) << lines[i];
      EXPECT_NEAR(v[3] - last_ramp, kDt, 1e-9) << lines[i];
    } else {
      EXPECT_EQ(v[0], 0.0) << "t starts at the first sample";
      first_cycle = v[1];
    }
    EXPECT_LT(v[0], 1.0);
    EXPECT_NEAR(std::round(v[0] / kDt) * kDt, v[0], 1e-9) << "t is on the task's grid";
    last_cycle = v[1];
    last_ramp = v[3];
    ++rows;
  }
  // Every cycle the task ran in that second (1000 unless it overran).
  EXPECT_EQ(static_cast<double>(rows), last_cycle - first_cycle + 1);
  EXPECT_LE(rows, 1000u);
  EXPECT_NE(r.out.find(std::to_string(rows) + " samples, 0 lost"), std::string::npos) << r.out;
  EXPECT_EQ(lines.back().rfind("# rtplc trace: runtime " + name_ + ", task ramp", 0), 0u) << lines.back();

  // Without --cycles, the header is the one `rtplc sim` writes for the same program.
  const auto t2 = run_tool("trace Rate Ramp PV PVcopy --name " + name_ + " --duration 0.05 -q --csv " + file("t2.csv"));
  ASSERT_EQ(t2.status, 0) << t2.out;
  const auto s = run_tool("sim " + file("ramp.fbd") + " --period 0.001 --duration 0.01 -q --csv " + file("s.csv"));
  ASSERT_EQ(s.status, 0) << s.out;
  EXPECT_EQ(lines_of(file("t2.csv"))[0], lines_of(file("s.csv"))[0]);
}

TEST_F(TraceTool, a_trigger_starts_the_recording_with_samples_before_it) {
  // Ramp passes 0.5 half a second after the start; wait for 0.5 more than now.
  const auto now = run_tool("trace Ramp --name " + name_ + " --duration 0.002 -q");
  ASSERT_EQ(now.status, 0) << now.out;
  const auto l = now.out.find('\n');
  const double ramp_now = numbers(now.out.substr(l + 1, now.out.find('\n', l + 1) - l - 1))[1];
  const double level = ramp_now + 0.5 + kDt / 2;  // between two steps of the ramp
  const auto r = run_tool("trace --cycles Ramp --name " + name_ + " --duration 0.1 --pre-trigger 0.02 --trigger 'Ramp>" +
                          std::to_string(level) + "' --csv " + file("trig.csv"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("triggered at cycle"), std::string::npos) << r.out;
  size_t before = 0, after = 0;
  double prev = -1, prev_cycle = -1;
  for (const std::string& line : lines_of(file("trig.csv"))) {
    if (line.empty() || line[0] == '#' || line[0] == 't') continue;
    const auto v = numbers(line);
    if (prev_cycle >= 0) {
      EXPECT_EQ(v[1], prev_cycle + 1) << line;
    }
    prev_cycle = v[1];
    if (v[0] < 0) {
      ++before;
      EXPECT_LT(v[2], level);
    } else {
      if (after == 0) {
        EXPECT_EQ(v[0], 0.0);
        EXPECT_GT(v[2], level) << "t = 0 is the first sample where the trigger holds";
        EXPECT_LT(prev, level);
      }
      EXPECT_LT(v[0], 0.1);
      ++after;
    }
    prev = v[2];
  }
  EXPECT_EQ(before, 20u) << "20 ms of pre-trigger samples";
  EXPECT_GT(after, 0u);
  EXPECT_LE(after, 100u);
}

TEST_F(TraceTool, a_stalled_tool_reports_the_samples_it_lost_and_fails) {
  // Stopped (SIGSTOP) for longer than the ring holds (2048 cycles at 1 ms).
  const std::string cmd = test::rtplc_binary() + " trace Ramp --cycles --name " + name_ +
                          " --duration 4 --csv " + file("lost.csv") + " >" + file("lost.out") + " 2>&1 & p=$!; " +
                          "sleep 0.5; kill -STOP $p; sleep 3; kill -CONT $p; wait $p; echo rc=$?";
  const auto r = run_shell(cmd);
  const std::string out = run_shell("cat " + file("lost.out")).out;
  EXPECT_NE(r.out.find("rc=1"), std::string::npos) << r.out << out;
  EXPECT_NE(out.find("INCOMPLETE"), std::string::npos) << out;
  size_t rows = 0, noted = 0;
  double first = -1, last = -1;
  for (const std::string& line : lines_of(file("lost.csv"))) {
    if (line.rfind("# lost ", 0) == 0) {
      noted += std::stoul(line.substr(7));
    } else if (!line.empty() && line[0] != '#' && line[0] != 't') {
      ++rows;
      last = numbers(line)[1];
      if (first < 0) first = last;
    }
  }
  EXPECT_GT(noted, 0u);
  EXPECT_EQ(static_cast<double>(rows + noted), last - first + 1)
      << "every cycle of the trace is either a row or counted lost";
  EXPECT_NE(out.find(std::to_string(noted) + " lost"), std::string::npos) << out;
}

TEST_F(TraceTool, says_what_it_traces_in_status_and_when_the_runtime_dies_under_it) {
  const std::string cmd = test::rtplc_binary() + " trace Ramp --name " + name_ + " --duration 60 --csv " +
                          file("dead.csv") + " >" + file("dead.out") + " 2>&1 & p=$!; " + "sleep 1; " +
                          test::rtplc_binary() + " status --name " + name_ + "; kill -9 " + std::to_string(pid_) +
                          "; wait $p; echo rc=$?";
  const auto r = run_shell(cmd);
  const std::string out = run_shell("cat " + file("dead.out")).out;
  EXPECT_NE(r.out.find("task ramp: running"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("traced (Ramp)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rc=1"), std::string::npos) << r.out << out;
  EXPECT_NE(out.find("runtime " + name_ + " is not running"), std::string::npos) << out;
  const auto lines = lines_of(file("dead.csv"));
  ASSERT_GT(lines.size(), 100u) << "what was recorded is written";
  EXPECT_EQ(lines.back().rfind("# ended early: runtime " + name_ + " is not running", 0), 0u) << lines.back();
}

TEST_F(TraceTool, draws_a_png) {
  if (run_shell("command -v gnuplot").status != 0) GTEST_SKIP() << "gnuplot is not installed";
  const auto r = run_tool("trace Ramp PV --name " + name_ + " --duration 0.3 -q --csv " + file("p.csv") +
                          " --plot " + file("p.png"));
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream png(file("p.png"), std::ios::binary);
  char magic[8] = {};
  png.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

TEST_F(TraceTool, refuses_nonsense_with_a_clear_error) {
  auto r = run_tool("trace Nope --name " + name_ + " --duration 1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("no channel is labelled \"Nope\""), std::string::npos) << r.out;
  r = run_tool("trace Ramp --name " + name_ + " --duration 0");
  EXPECT_EQ(r.status, 2) << r.out;
  r = run_tool("trace Ramp --name " + name_ + " --duration nan");
  EXPECT_EQ(r.status, 2) << r.out;
  r = run_tool("trace Ramp --name " + name_ + " --trigger Ramp");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("LABEL>VALUE"), std::string::npos) << r.out;
  r = run_tool("trace Ramp --name " + name_ + " --pre-trigger 1");
  EXPECT_EQ(r.status, 2) << r.out;
  r = run_tool("trace Ramp --name nobody-runs-this --duration 1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("no runtime named 'nobody-runs-this' is running"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace rtplc::sched
