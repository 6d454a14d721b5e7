// No wrong data shown as good: a swap that would leave an output behind is
// refused (or, asked for, drops it to its safe value with bad quality and the
// driver stops applying it); a runtime killed with -9 is reported dead by every
// tool, its channels stale, with a non-zero exit; a swap applied but never
// collected leaks no program.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <thread>

#include "io/drivers/s7/fake_plc.h"
#include "sched/control.h"
#include "tests/support/run_tool.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

// The seed loop: ProcVal from the plant, ManiVal to it, and a second output.
const char* kLoop =
    "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F3 = sub(F2, F1, 1)\nF4 = epi(F3, 4, 3)\n"
    "dao(F4, p0, d0, c0, \"ManiVal\")\ndao(F3, p0, d0, c1, \"Error\")\nEND\n";
// The same without the ManiVal output.
const char* kLoopWithoutManiVal =
    "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F3 = sub(F2, F1, 1)\nF4 = epi(F3, 4, 3)\n"
    "dao(F3, p0, d0, c1, \"Error\")\nEND\n";

io::ChannelValue read_label(Runtime& rt, const std::string& label) {
  const int c = rt.image().find_channel(label);
  EXPECT_GE(c, 0) << label;
  return rt.image().read_channel(static_cast<uint32_t>(c));
}

TEST(WrongData, a_swap_that_leaves_out_an_output_is_refused_with_its_label) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  auto rt = fx.start("tasks:\n  - {name: pid, program: loop.fbd, period: 10ms}\ndrivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  sleep_s(0.3);  // the first release is 0.1 s after start; then a few cycles
  auto r = rt->swap("pid", kLoopWithoutManiVal, "nomv.fbd");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("ManiVal"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("--drop-output ManiVal"), std::string::npos) << r.error();
  EXPECT_EQ(rt->image().task_info(0).swaps.load(), 0u);
  EXPECT_EQ(read_label(*rt, "ManiVal").quality, Quality::kGood);
  // Naming an output the swap does not leave out is refused too.
  EXPECT_FALSE(rt->swap("pid", kLoop, "same.fbd", {"Error"}).ok());
  rt->stop();
}

TEST(WrongData, a_dropped_output_goes_safe_and_bad_and_the_plant_no_longer_follows_it) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  auto rt = fx.start(
      "tasks:\n  - {name: pid, program: loop.fbd, period: 10ms, safe_outputs: {ManiVal: 7}}\n"
      "drivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  sleep_s(0.3);
  auto r = rt->swap("pid", kLoopWithoutManiVal, "nomv.fbd", {"ManiVal"});
  ASSERT_TRUE(r.ok()) << r.error();
  sleep_s(0.2);  // every ring slot rewritten several times
  // Read it many times: every snapshot of the ring must say the same.
  for (int i = 0; i < 50; ++i) {
    const io::ChannelValue v = read_label(*rt, "ManiVal");
    EXPECT_EQ(v.value, 7.0);
    EXPECT_EQ(v.quality, Quality::kBad);
    sleep_s(0.002);
  }
  EXPECT_EQ(read_label(*rt, "Error").quality, Quality::kGood);
  // The plant holds its last input: the driver's delivery entry says bad, so
  // the output reads bad even through its driver.
  rt->stop();
}

// A program published to a task, taken by the task thread, but never collected
// by the control thread (the runtime shuts down first) is still freed.
TEST(WrongData, a_swap_taken_but_never_collected_leaks_no_program) {
  const uint64_t before = LoadedProgram::live_count();
  {
    RuntimeFixture fx;
    fx.write("loop.fbd", kLoop);
    auto rt = fx.start("tasks:\n  - {name: pid, program: loop.fbd, period: 5ms}\ndrivers:\n  - kind: sim\n");
    ASSERT_NE(rt, nullptr);
    Task& t = rt->task(0);
    const LoadedProgram& cur = t.active();
    auto next = std::make_unique<LoadedProgram>();
    auto copy = TaskImage::from_bytes(cur.image.bytes());
    ASSERT_TRUE(copy.ok());
    next->image = std::move(copy).value();
    next->arena.resize_for(next->image);
    next->lane.resize_for(next->image);
    next->inputs = cur.inputs;
    next->output_slots = cur.output_slots;
    next->outputs_in_place = cur.outputs_in_place;
    next->safe_values = cur.safe_values;
    next->output_quality = cur.output_quality;
    next->region_quality = cur.output_quality;
    ASSERT_TRUE(t.publish(std::move(next)));
    for (int i = 0; i < 400 && !t.swap_applied(); ++i) sleep_s(0.005);
    ASSERT_TRUE(t.swap_applied());
    rt->stop();
  }  // no collect(): the runtime and its tasks go away here
  EXPECT_EQ(LoadedProgram::live_count(), before);
}

using rtplc::test::run_tool;
using rtplc::test::ToolRun;

TEST(WrongData, after_kill_9_every_tool_says_not_running_shows_stale_and_fails) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  const std::string name = fx.unique_name();
  const std::string sock = fx.dir() + "/k.sock";
  const std::string cfg = fx.write("k.yaml", "runtime:\n  name: " + name + "\n  socket: " + sock +
                                                 "\n  retain_file: " + fx.dir() + "/k.retain\n"
                                                 "tasks:\n  - {name: pid, program: loop.fbd, period: 10ms}\n"
                                                 "drivers:\n  - kind: sim\n");
  const std::string bin = std::string(RTPLC_BINARY_DIR) + "/rtplc";
  const pid_t pid = fork();
  if (pid == 0) {
    execl(bin.c_str(), bin.c_str(), "run", cfg.c_str(), "-q", "--no-lock", nullptr);
    _exit(127);
  }
  bool up = false;
  for (int i = 0; i < 200 && !up; ++i) {
    up = control_request(sock, "ping", "", 500).ok();
    if (!up) sleep_s(0.05);
  }
  ASSERT_TRUE(up);
  ToolRun live = run_tool("monitor --once --name " + name);
  EXPECT_EQ(live.status, 0) << live.out;
  EXPECT_NE(live.out.find("good"), std::string::npos) << live.out;
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);

  ToolRun mon = run_tool("monitor --once --name " + name);
  EXPECT_NE(mon.status, 0) << mon.out;
  EXPECT_NE(mon.out.find("not running (died at"), std::string::npos) << mon.out;
  EXPECT_EQ(mon.out.find(" good "), std::string::npos) << "a dead runtime's value shown good:\n" << mon.out;
  EXPECT_NE(mon.out.find("stale"), std::string::npos) << mon.out;

  ToolRun stats = run_tool("stats --name " + name);
  EXPECT_NE(stats.status, 0) << stats.out;
  EXPECT_NE(stats.out.find("not running (died at"), std::string::npos) << stats.out;

  ToolRun status = run_tool("status --name " + name + " --socket " + sock);
  EXPECT_NE(status.status, 0) << status.out;
  EXPECT_NE(status.out.find("not running (died at"), std::string::npos) << status.out;
  shm_unlink(io::ProcessImage::shm_name(name).c_str());
}

// The figures `rtplc run` prints when it stops include every link's line.
TEST(WrongData, the_stats_printed_at_shutdown_include_the_link_lines) {
  s7::FakePlc plc;
  auto ep = plc.add_endpoint({"127.0.0.1", 0, {}});
  ASSERT_TRUE(ep.ok()) << ep.error();
  ASSERT_TRUE(plc.start().ok());
  RuntimeFixture fx;
  fx.write("e.fbd", "%%\nF1 = era(p1, d0, c0, \"Volt\")\newa(F1, p1, d0, c1, \"Echo\")\nEND\n");
  const std::string name = fx.unique_name();
  const std::string cfg = fx.write(
      "e.yaml", "runtime:\n  name: " + name + "\n  socket: " + fx.dir() + "/e.sock\n  retain_file: " + fx.dir() +
                    "/e.retain\ntasks:\n  - {name: e, program: e.fbd, period: 10ms}\ndrivers:\n  - kind: s7\n"
                    "    plcs: [{name: panel01, address: 127.0.0.1, port: " + std::to_string(plc.port(0)) +
                    ", poll: 50ms}]\n    read: [{channel: p1.d0.c0, plc: panel01, item: DB10.DBD0:REAL}]\n"
                    "    write: [{channel: p1.d0.c1, plc: panel01, item: DB10.DBD4:REAL}]\n");
  ToolRun r = run_tool("run " + cfg + " --duration 1.5 --no-lock");
  plc.stop();
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("T: 0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("L: 0 (panel01) s7 127.0.0.1:" + std::to_string(plc.port(0)) + " up"), std::string::npos)
      << r.out;
}

}  // namespace
}  // namespace rtplc::sched
