// The runtime running for real: periods kept, overruns counted and handled by
// policy without disturbing a higher-priority task, the watchdog, swaps every
// few cycles for thousands of cycles without a missed release or a bump, no page
// faults in the cycle, retained values surviving kill -9, and bad input for a
// swap changing nothing. Assertions are about counts and values, never about
// how long something took on this machine.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <thread>

#include "kernel_rt/clock.h"
#include "kernel_rt/memory.h"
#include "kernel_rt/rt_thread.h"
#include "sched/control.h"
#include "sched/jitter.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

const CycleStats& stats_of(Runtime& rt, uint32_t t) {
  return *static_cast<const CycleStats*>(rt.image().task_stats(t));
}

// The releases a task passed while it ran lie between the periods counted up
// to the stop request and those counted up to the moment stop() returned: the
// task sees the request at its next release, after it, or never again (joined).
// Bracketing both ends makes the count exact on any machine, however slow
// stop() is here: no allowance for how long anything took.
struct Span {
  int64_t before_stop = 0;  // CLOCK_MONOTONIC, ns
  int64_t after_stop = 0;
};
Span run_then_stop(Runtime& rt, double seconds) {
  sleep_s(seconds);
  Span s;
  s.before_stop = kernel_rt::monotonic_now_ns();
  rt.stop();
  s.after_stop = kernel_rt::monotonic_now_ns();
  return s;
}
void expect_releases_accounted(Runtime& rt, uint32_t t, const Span& span) {
  // Every release lies on the task's own grid (its first release, then one per
  // period): cycles run + releases skipped account for every release that
  // passed, no more and no fewer.
  const CycleStats& st = stats_of(rt, t);
  const int64_t first = rt.task(t).first_release_ns();
  const int64_t period_ns = rt.task(t).params().period_ns;
  const std::string& name = rt.task(t).params().name;
  const uint64_t accounted = st.cycles() + st.skipped_releases();
  const auto lo = static_cast<uint64_t>((span.before_stop - first) / period_ns) + 1;
  const auto hi = static_cast<uint64_t>((span.after_stop - first) / period_ns) + 1;
  EXPECT_GE(accounted, lo) << name;
  EXPECT_LE(accounted, hi) << name;
}

// A small loop on its own channels: set-point k, output k.
std::string small_program(int k) {
  const std::string n = std::to_string(k);
  return "%%\nF1 = asp(d0, c" + n + ", 1, \"SP" + n + "\")\nF2 = intg(F1, 1)\nF3 = lim(F2, 0, 1e9)\n"
         "dao(F3, p0, d0, c" + n + ", \"OUT" + n + "\")\nEND\n";
}

// `n` sine blocks in a chain: work that takes a known while.
std::string heavy_program(int n = 10000) {
  std::string s = "%%\nF1 = asp(d0, c9, 0.5, \"HSP\")\n";
  for (int i = 2; i < n + 2; ++i) s += "F" + std::to_string(i) + " = sin(F" + std::to_string(i - 1) + ")\n";
  s += "dao(F" + std::to_string(n + 1) + ", p0, d0, c9, \"HOUT\")\nEND\n";
  return s;
}

TEST(Runtime, tasks_keep_their_periods) {
  RuntimeFixture fx;
  for (int k = 0; k < 3; ++k) fx.write("p" + std::to_string(k) + ".fbd", small_program(k));
  auto rt = fx.start(
      "tasks:\n"
      "  - {name: fast, program: p0.fbd, period: 2ms}\n"
      "  - {name: mid, program: p1.fbd, period: 5ms}\n"
      "  - {name: slow, program: p2.fbd, period: 10ms}\n");
  ASSERT_NE(rt, nullptr);
  const Span span = run_then_stop(*rt, 1.3);
  for (uint32_t t = 0; t < 3; ++t) {
    const CycleStats& st = stats_of(*rt, t);
    const std::string& name = rt->task(t).params().name;
    expect_releases_accounted(*rt, t, span);
    // And most of them ran. How many a task skips is the machine's noise (a
    // shared VM steals the CPU for milliseconds, whatever the priority), so it
    // belongs to the jitter benchmark; this only catches a task that lost its
    // grid, e.g. one that ran at twice its period.
    EXPECT_GT(st.cycles(), (st.cycles() + st.skipped_releases()) / 2) << name;
  }
  // Rate-monotonic: the shorter the period, the higher the priority.
  EXPECT_GT(rt->task(0).params().priority, rt->task(1).params().priority);
  EXPECT_GT(rt->task(1).params().priority, rt->task(2).params().priority);
}

TEST(Runtime, an_overrunning_task_is_counted_and_does_not_disturb_a_higher_priority_one) {
  if (!rtplc::testing::can_use_fifo()) GTEST_SKIP() << "needs SCHED_FIFO (root or CAP_SYS_NICE)";
  const unsigned cpu = kernel_rt::allowed_cpu_count() > 1 ? 1 : 0;
  RuntimeFixture fx;
  fx.write("light.fbd", small_program(0));
  const std::string heavy = heavy_program(40000);
  fx.write("heavy.fbd", heavy);
  const std::string c = std::to_string(cpu);
  // The heavy task needs 1.3 periods per cycle: it overruns every time, yet with
  // the skipped releases it leaves the CPU idle part of the time (so the
  // kernel's RT throttling, which would stall every RT task, never kicks in).
  // The measurement is the machine's of the moment: beside stress-ng under
  // ThreadSanitizer it once came out a third slower than the task then ran,
  // and the heavy task overran 10 cycles of 500. So the period shrinks until
  // the heavy task does overrun (at most four tries), and the light task is
  // judged in that run.
  const int64_t exec = rtplc::testing::measure_exec_ns(heavy);
  int64_t period_us = std::max<int64_t>(100, exec / 1300);
  std::unique_ptr<Runtime> rt;
  Span span;
  for (int attempt = 0; attempt < 4; ++attempt, period_us = std::max<int64_t>(100, period_us * 6 / 10)) {
    rt.reset();
    rt = fx.start(
        "tasks:\n"
        "  - {name: light, program: light.fbd, period: 1ms, priority: 40, cpu: " + c + "}\n"
        "  - {name: heavy, program: heavy.fbd, period: " + std::to_string(period_us) +
        "us, priority: 20, cpu: " + c + "}\n");
    ASSERT_NE(rt, nullptr);
    if (!rt->image().task_info(0).fifo || !rt->image().task_info(1).fifo) {
      rt->stop();
      GTEST_SKIP() << "the tasks did not get SCHED_FIFO: priorities mean nothing under SCHED_OTHER";
    }
    span = run_then_stop(*rt, 1.5);
    const CycleStats& h = stats_of(*rt, 1);
    if (h.overruns() > h.cycles() / 2) break;
    std::printf("note: the heavy task overran %llu of %llu cycles at %lld us; trying a shorter period\n",
                static_cast<unsigned long long>(h.overruns()), static_cast<unsigned long long>(h.cycles()),
                static_cast<long long>(period_us));
  }
  const CycleStats& light = stats_of(*rt, 0);
  const CycleStats& heavy_st = stats_of(*rt, 1);
  // The heavy task overran (nearly) every cycle, skipped releases, and went on.
  EXPECT_GT(heavy_st.overruns(), heavy_st.cycles() / 2);
  EXPECT_GE(heavy_st.skipped_releases(), heavy_st.overruns());
  EXPECT_EQ(static_cast<io::TaskState>(rt->image().task_info(1).state.load()), io::TaskState::kStopped);
  // The light task kept its period and was not held up by the heavy one: if it
  // had to wait for a heavy cycle, its wake latency would be a heavy cycle long.
  expect_releases_accounted(*rt, 0, span);
  // The bounds below leave room for the host stealing this VM's CPU now and
  // then (that hits every task, whatever its priority); a light task held up by
  // the heavy one would be late in most of its cycles, not a few.
  EXPECT_LE(light.overruns(), light.cycles() / 20);
  const StatsSnapshot lw = snapshot(light, Series::kWake);
  const StatsSnapshot he = snapshot(heavy_st, Series::kExec);
  EXPECT_LT(lw.p90_ns, he.p50_ns / 2) << "light p90 wake " << lw.p90_ns << " ns, heavy cycle " << he.p50_ns
                                      << " ns";
}

TEST(Runtime, the_watchdog_stops_a_task_and_sets_its_outputs_safe) {
  RuntimeFixture fx;
  fx.write("heavy.fbd", heavy_program());
  auto rt = fx.start(
      "tasks:\n"
      "  - name: heavy\n    program: heavy.fbd\n    period: 100us\n    overrun: stop\n    watchdog: 3\n"
      "    safe_outputs: {HOUT: -7}\n");
  ASSERT_NE(rt, nullptr);
  for (int i = 0; i < 100 && rt->image().task_info(0).state.load() !=
                                 static_cast<uint8_t>(io::TaskState::kStoppedWatchdog); ++i) {
    sleep_s(0.02);
  }
  EXPECT_EQ(static_cast<io::TaskState>(rt->image().task_info(0).state.load()),
            io::TaskState::kStoppedWatchdog);
  EXPECT_EQ(rtplc::testing::channel_value(*rt, "HOUT"), -7.0);
  EXPECT_EQ(stats_of(*rt, 0).max_consecutive_overruns(), 3u);
  // Stopped means stopped: no more overruns pile up.
  const uint64_t overruns = stats_of(*rt, 0).overruns();
  sleep_s(0.1);
  EXPECT_EQ(stats_of(*rt, 0).overruns(), overruns);
  rt->stop();
}

// A deterministic loop: an integrator and a PID with a constant error. After k
// cycles F2 = k*dt and the PID's integral is k*e*dt/Ti — any lost state, lost or
// doubled cycle across a swap shows in these two numbers.
std::string counting_program(bool variant) {
  return std::string("%%\nF1 = asp(d0, c0, 1, \"ONE\")\nF4 = asp(d0, c1, 0.5, \"E\")\n"
                     "F2 = intg(F1, 1)\nF5 = asp(d0, c2, 0, \"ZERO\")\nF3 = pid(F4, F5, 2, 4, 0)\n") +
         (variant ? "F9 = abs(F3)\nF10 = scale(F9, 2, 1)\n" : "F9 = abs(F2)\n") +
         "dao(F2, p0, d0, c0, \"RAMP\")\ndao(F3, p0, d0, c1, \"PIDOUT\")\nEND\n";
}

TEST(Runtime, swapping_every_few_cycles_misses_no_release_and_loses_no_state) {
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  auto rt = fx.start("tasks:\n  - {name: loop, program: a.fbd, period: 1ms}\n");
  ASSERT_NE(rt, nullptr);
  const std::string a = counting_program(false), b = counting_program(true);
  int swaps = 0;
  for (int i = 0; i < 1000; ++i) {
    auto r = rt->swap("loop", i % 2 ? a : b, i % 2 ? "a.fbd" : "b.fbd");
    ASSERT_TRUE(r.ok()) << r.error();
    ++swaps;
    rt->reap();
    sleep_s(0.003);  // a few cycles between swaps
  }
  rt->stop();
  const CycleStats& st = stats_of(*rt, 0);
  EXPECT_EQ(rt->image().task_info(0).swaps.load(), static_cast<uint64_t>(swaps));
  EXPECT_GT(st.cycles(), 3000u);
  // Swaps cause no missed release: the cycles that took a new program overrun no
  // more often than any other cycle. (On a loaded machine that is not PREEMPT_RT,
  // an occasional cycle overruns whatever it does; a quarter of these cycles are
  // swap cycles, so one such overrun may land on one. A swap that cost time
  // would show here as hundreds.)
  const uint64_t swap_overruns = rt->image().task_info(0).swap_overruns.load();
  const double swap_share = static_cast<double>(swaps) / static_cast<double>(st.cycles());
  if (kernel_rt::memory_locking_supported()) {
    EXPECT_LE(static_cast<double>(swap_overruns), 3.0 * swap_share * static_cast<double>(st.overruns()) + 1.0);
  } else {
    // A sanitizer build keeps its shadow memory paged out, so the first cycle of
    // each new program faults that shadow in: its swap cycles are slow for the
    // tool's sake, not ours. The release suite holds the timing to account; here
    // the state and the count of swaps below are still checked.
    std::printf("swap-cycle overruns not compared: this build cannot lock its memory\n");
  }
  std::printf("%d swaps over %llu cycles: %llu overruns in all, %llu releases skipped, %llu in swap cycles\n",
              swaps, static_cast<unsigned long long>(st.cycles()), static_cast<unsigned long long>(st.overruns()),
              static_cast<unsigned long long>(st.skipped_releases()),
              static_cast<unsigned long long>(swap_overruns));
  // The final program's arena: every cycle ever run is in its state.
  const LoadedProgram& p = rt->task(0).active();
  const double k = static_cast<double>(p.arena.cycles);
  EXPECT_EQ(p.arena.cycles, st.cycles());
  EXPECT_NEAR(rtplc::testing::block_value(p, "F2"), k * 0.001, 1e-9 * k);                       // RAMP
  EXPECT_NEAR(rtplc::testing::block_value(p, "F3"), 2 * (0.5 + k * 0.5 * 0.001 / 4), 1e-9 * k);  // PID
}

TEST(Runtime, no_page_faults_in_the_cycle_after_warm_up) {
  if (!kernel_rt::memory_locking_supported()) {
    GTEST_SKIP() << "this build's sanitizer keeps its own shadow memory paged out; memory cannot be locked";
  }
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  RuntimeOptions opt;
  opt.count_faults = true;
  auto rt = fx.start("tasks:\n  - {name: loop, program: a.fbd, period: 1ms}\n", opt);
  ASSERT_NE(rt, nullptr);
  sleep_s(0.3);
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE(rt->swap("loop", counting_program(i % 2 == 0), "x.fbd").ok());
    sleep_s(0.02);
  }
  rt->stop();
  EXPECT_GT(stats_of(*rt, 0).cycles(), 500u);
  EXPECT_EQ(rt->image().task_info(0).minor_faults.load(), 0u);
}

TEST(Runtime, a_bad_program_for_swap_changes_nothing) {
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  auto rt = fx.start("tasks:\n  - {name: loop, program: a.fbd, period: 2ms}\n");
  ASSERT_NE(rt, nullptr);
  sleep_s(0.05);
  const std::string before = rt->task(0).active().source;
  for (const char* bad : {"%%\nF1 = nope(F2)\nEND\n", "", "\x01\x02garbage", "%%\nF1 = asp(d0, c0, 1, \"ONE\")\n"
                                                                           "dao(F1, p0, d0, c0, \"PIDOUT\")\nEND\n"}) {
    auto r = rt->swap("loop", bad, "bad.fbd");
    EXPECT_FALSE(r.ok()) << bad;
  }
  EXPECT_FALSE(rt->swap("nosuchtask", counting_program(true), "x.fbd").ok());
  EXPECT_FALSE(rt->rollback("loop").ok());  // nothing to roll back to yet
  EXPECT_EQ(rt->image().task_info(0).swaps.load(), 0u);
  EXPECT_EQ(rt->task(0).active().source, before);
  const uint64_t c1 = stats_of(*rt, 0).cycles();
  sleep_s(0.05);
  EXPECT_GT(stats_of(*rt, 0).cycles(), c1);  // still running
  rt->stop();
}

TEST(Runtime, rollback_returns_to_the_previous_code_with_its_state) {
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  auto rt = fx.start("tasks:\n  - {name: loop, program: a.fbd, period: 2ms}\n");
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(rt->swap("loop", counting_program(true), "b.fbd").ok());
  EXPECT_EQ(rt->task(0).active().file, "b.fbd");
  auto r = rt->rollback("loop");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(rt->task(0).active().source, counting_program(false));
  sleep_s(0.05);
  rt->stop();
  const LoadedProgram& p = rt->task(0).active();
  const double k = static_cast<double>(p.arena.cycles);
  EXPECT_NEAR(rtplc::testing::block_value(p, "F2"), k * 0.002, 1e-9 * k);
}

// The control thread waits up to a period for a swap's boundary; the tools'
// liveness check (3 s without a heartbeat: dead) must not fire meanwhile.
TEST(Runtime, a_swap_on_a_slow_task_does_not_stall_the_heartbeat) {
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  auto rt = fx.start("tasks:\n  - {name: slow, program: a.fbd, period: 5s}\n");
  ASSERT_NE(rt, nullptr);
  sleep_s(0.2);  // past the first cycle: the swap waits for the next, 5 s on
  std::atomic<bool> done{false};
  std::thread swapper([&] {
    EXPECT_TRUE(rt->swap("slow", counting_program(true), "b.fbd").ok());
    done = true;
  });
  sleep_s(3.6);  // nothing else beats: only the runtime's own heartbeat thread
  EXPECT_FALSE(done.load()) << "the swap was expected to wait for the 5 s boundary";
  const io::Liveness l = rt->image().liveness();
  EXPECT_TRUE(l.alive) << l.why;
  swapper.join();
  rt->stop();
  EXPECT_FALSE(rt->image().liveness().alive) << "a stopped runtime is not alive";
}

TEST(Runtime, a_malformed_config_or_program_starts_nothing_and_leaves_nothing) {
  RuntimeFixture fx;
  fx.write("bad.fbd", "%%\nF1 = pdi(F2)\nEND\n");
  std::string errors;
  auto rt = fx.load("tasks:\n  - {name: x, program: bad.fbd}\n", &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("bad.fbd:2:6: error: unknown block 'pdi'"), std::string::npos) << errors;
  errors.clear();
  rt = fx.load("tasks:\n  - {name: x, program: nothere.fbd, perod: 1ms}\n", &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_FALSE(errors.empty());
  // Two tasks writing one output: refused with both named.
  fx.write("o1.fbd", small_program(0));
  errors.clear();
  rt = fx.load("tasks:\n  - {name: a, program: o1.fbd}\n  - {name: b, program: o1.fbd}\n", &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("already written by task a"), std::string::npos) << errors;
}

TEST(Runtime, set_points_change_live_and_are_retained) {
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  const std::string yaml = "tasks:\n  - {name: loop, program: a.fbd, period: 2ms}\n";
  auto rt = fx.start(yaml);
  ASSERT_NE(rt, nullptr);
  auto r = rt->set_value("E", 0.25);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_FALSE(rt->set_value("RAMP", 1).ok());      // an output
  EXPECT_FALSE(rt->set_value("NOPE", 1).ok());
  EXPECT_FALSE(rt->set_value("E", std::nan("")).ok());
  sleep_s(0.05);
  EXPECT_EQ(rtplc::testing::channel_value(*rt, "E"), 0.25);
  const std::string retain = rt->retain_path();
  rt.reset();
  RetainStore store(retain);
  ASSERT_TRUE(store.load().ok());
  EXPECT_EQ(store.get("E"), 0.25);
}

// The real binary, killed with SIGKILL right after `rtplc set` answered.
TEST(Runtime, kill_9_loses_no_retained_value) {
  RuntimeFixture fx;
  fx.write("a.fbd", counting_program(false));
  const std::string name = fx.unique_name();
  const std::string sock = fx.dir() + "/k.sock";
  const std::string cfg = fx.write("k.yaml", "runtime:\n  name: " + name + "\n  socket: " + sock +
                                                 "\n  retain_file: " + fx.dir() + "/k.retain\n"
                                                 "tasks:\n  - {name: loop, program: a.fbd, period: 5ms}\n");
  auto launch = [&] { return rtplc::testing::launch_rtplc_run(cfg, sock); };
  pid_t pid = launch();
  for (int i = 0; i < 20; ++i) {
    auto r = control_request(sock, "set E " + std::to_string(0.5 + i));
    ASSERT_TRUE(r.ok()) << r.error();
  }
  kill(pid, SIGKILL);  // no chance to flush anything
  waitpid(pid, nullptr, 0);
  pid = launch();
  auto img = io::ProcessImage::attach(name);
  ASSERT_TRUE(img.ok()) << img.error();
  const int c = img->find_channel("E");
  ASSERT_GE(c, 0);
  double v = 0;
  for (int i = 0; i < 50 && (v = img->read_channel(static_cast<uint32_t>(c)).value) != 19.5; ++i) sleep_s(0.02);
  EXPECT_EQ(v, 19.5);
  (void)control_request(sock, "stop");
  waitpid(pid, nullptr, 0);
}

}  // namespace
TEST(Runtime, a_ten_thousand_block_task_uses_under_half_of_its_stack) {
  // Every thread's stack is resident and locked for its whole size, so each is
  // sized to what it uses: this holds the task's size to account.
  RuntimeFixture fx;
  fx.write("heavy.fbd", heavy_program(10000));
  auto rt = fx.start("tasks:\n  - {name: heavy, program: heavy.fbd, period: 5ms}\n");
  ASSERT_NE(rt, nullptr);
  sleep_s(0.2);
  rt->stop();
  ASSERT_GT(stats_of(*rt, 0).cycles(), 0u);
  const size_t used = rt->task(0).stack_high_water();
  if (used == 0) GTEST_SKIP() << "stack depth is not measured in a sanitizer build";
  EXPECT_LT(used, rt->task(0).stack_bytes() / 2) << used << " of " << rt->task(0).stack_bytes() << " bytes";
}

}  // namespace rtplc::sched
