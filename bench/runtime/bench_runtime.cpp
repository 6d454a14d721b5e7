// Two runtime benchmarks on the 10,000-block program (bench/support), measured
// side by side in one run and reported as ratios:
//  1. Cycle overhead of the runtime itself — input exchange, publishing the
//     outputs into the shared process image, the jitter monitor — against the
//     bare executor. Measured two ways, alternating in rounds: back to back
//     (warm caches: what the runtime adds, precisely) and as SCHED_FIFO threads
//     at a 1 ms period (the real setting, where a cold cache after each sleep
//     adds noise of its own). Goal: <= 1.05.
//  2. Hot swap of that 10,000-block task at a 1 ms period: time from request to
//     the first cycle on the new code, and releases missed because of a swap
//     (goal 0), over many swaps.
//   build/release/bench/bench_runtime [--seconds S] [--swaps N]
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/support/loop_program.h"
#include "config/config.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_process.h"
#include "kernel_rt/rt_thread.h"
#include "lang/compiler.h"
#include "sched/jitter.h"
#include "sched/runtime.h"

using namespace rtplc;

namespace {

constexpr int kLoops = 715;            // 10,010 blocks
constexpr int64_t kPeriodNs = 1000000;  // 1 ms

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

// The bare executor back to back, warm: ns per cycle.
double bare_hot(const TaskImage& image, double seconds) {
  TaskArena arena(image);
  const ExecContext ctx = make_context(image, arena);
  double per_cycle = 0;
  kernel_rt::ThreadSpec spec{"bench-hot", 80, {}, 512 * 1024, 256 * 1024};
  auto th = kernel_rt::start_thread(spec, [&] {
    const int64_t start = kernel_rt::monotonic_now_ns();
    const int64_t end = start + static_cast<int64_t>(seconds * 1e9);
    uint64_t n = 0;
    int64_t now = start;
    // Timed like a task's cycle: a clock read before and after each one.
    int64_t busy = 0;
    while (now < end) {
      const int64_t a = kernel_rt::monotonic_now_ns();
      execute_cycle(ctx);
      now = kernel_rt::monotonic_now_ns();
      busy += now - a;
      ++n;
    }
    (void)busy;
    // Wall time per cycle, everything included (as for the runtime below).
    per_cycle = static_cast<double>(now - start) / static_cast<double>(n);
  });
  if (th) th->join();
  return per_cycle;
}

// The bare executor as a periodic FIFO thread: the reference for the overhead.
std::vector<double> bare_exec_times(const TaskImage& image, double seconds) {
  TaskArena arena(image);
  const ExecContext ctx = make_context(image, arena);
  std::vector<double> t;
  t.reserve(static_cast<size_t>(seconds * 1e9 / kPeriodNs) + 16);
  kernel_rt::ThreadSpec spec{"bench-bare", 80, {}, 512 * 1024, 256 * 1024};
  auto th = kernel_rt::start_thread(spec, [&] {
    int64_t release = kernel_rt::monotonic_now_ns() + kPeriodNs;
    const int64_t end = release + static_cast<int64_t>(seconds * 1e9);
    while (release < end) {
      kernel_rt::sleep_until_ns(release);
      const int64_t a = kernel_rt::monotonic_now_ns();
      execute_cycle(ctx);
      const int64_t b = kernel_rt::monotonic_now_ns();
      t.push_back(static_cast<double>(b - a));
      release += kPeriodNs;
      while (release < b) release += kPeriodNs;
    }
  });
  if (th) th->join();
  return t;
}

std::string temp_dir() {
  char tmpl[] = "/tmp/rtplc-bench-XXXXXX";
  return mkdtemp(tmpl);
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 20;
  int swaps = 200;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--seconds") == 0) seconds = std::atof(argv[i + 1]);
    if (std::strcmp(argv[i], "--swaps") == 0) swaps = std::atoi(argv[i + 1]);
  }
  const std::string src = bench::loop_program(kLoops, 0.001);
  // The swap alternates with a variant whose every block keeps its state.
  std::string src_b = src;
  src_b.insert(src_b.find("END\n"), "F999999 = asp(d9, c0, 1, \"BENCHX\")\n");

  const std::string dir = temp_dir();
  std::ofstream(dir + "/big.fbd") << src;
  std::ofstream(dir + "/bench.yaml") << "runtime:\n  name: bench" + std::to_string(getpid()) +
                                            "\n  socket: " + dir + "/s.sock\n  retain_file: " + dir +
                                            "/r.retain\n  priority_band: [10, 80]\ntasks:\n  - {name: big, program: big.fbd, "
                                            "period: 1ms, priority: 80}\n";
  auto cfg = config::load_config(dir + "/bench.yaml");
  if (!cfg.ok()) {
    std::fputs(cfg.render().c_str(), stderr);
    return 1;
  }
  auto compiled = lang::compile_source(src);
  if (!compiled.ok()) return 1;
  std::printf("== rtplc runtime benchmarks: %u-block task, period 1 ms, %g s per measurement ==\n",
              compiled.image->header().n_instr, seconds);
  auto rtproc = kernel_rt::prepare_process_for_rt();
  for (const auto& n : rtproc.notices) std::printf("# %s\n", n.c_str());

  // ---- 1. overhead --------------------------------------------------------
  // Bare and runtime alternate in rounds so drifts of the machine (clock
  // frequency, other load) hit both alike; the runtime is loaded afresh per round.
  const int rounds = 10;
  const double round_s = seconds / rounds;
  std::vector<double> bare_avg, rt_avg, hot_bare, hot_rt;
  uint64_t rt_cycles = 0, bare_cycles = 0;
  for (int round = 0; round < rounds; ++round) {
    // Back to back, warm. A busy FIFO thread is throttled by the kernel after
    // 950 ms in any second (sched_rt_runtime_us); the pauses keep both
    // measurements well inside that budget.
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    hot_bare.push_back(bare_hot(*compiled.image, round_s / 4));
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    {
      sched::LoadReport report;
      sched::RuntimeOptions opt;
      opt.back_to_back = true;
      auto rt = sched::Runtime::load(*cfg.config, opt, report);
      if (!rt || !rt->start().ok()) {
        std::fputs(report.render().c_str(), stderr);
        return 1;
      }
      // Wall time per cycle over a window in the middle of the run: the whole
      // cycle — inputs, executor, publishing, the jitter monitor, the loop.
      const auto* st = static_cast<const sched::CycleStats*>(rt->image().task_stats(0));
      std::this_thread::sleep_for(std::chrono::duration<double>(round_s / 16));
      const uint64_t c1 = st->cycles();
      const int64_t t1 = kernel_rt::monotonic_now_ns();
      std::this_thread::sleep_for(std::chrono::duration<double>(round_s / 4));
      const uint64_t c2 = st->cycles();
      const int64_t t2 = kernel_rt::monotonic_now_ns();
      rt->stop();
      hot_rt.push_back(static_cast<double>(t2 - t1) / static_cast<double>(c2 - c1));
    }
    const std::vector<double> bare = bare_exec_times(*compiled.image, round_s);
    double sum = 0;
    for (double v : bare) sum += v;
    bare_avg.push_back(sum / static_cast<double>(bare.size()));
    bare_cycles += bare.size();
    sched::LoadReport report;
    auto rt = sched::Runtime::load(*cfg.config, {}, report);
    if (!rt) {
      std::fputs(report.render().c_str(), stderr);
      return 1;
    }
    if (auto st = rt->start(); !st) {
      std::fprintf(stderr, "%s\n", st.error().c_str());
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(round_s));
    rt->stop();
    const auto* st = static_cast<const sched::CycleStats*>(rt->image().task_stats(0));
    rt_avg.push_back(static_cast<double>(st->exec().sum_ns.load()) / static_cast<double>(st->cycles()));
    rt_cycles += st->cycles();
  }
  std::printf("\n-- cycle overhead (input exchange + publishing outputs + jitter monitor) --\n");
  std::vector<double> hot_ratio;
  for (size_t r = 0; r < hot_rt.size(); ++r) hot_ratio.push_back(hot_rt[r] / hot_bare[r]);
  std::printf("  back to back (warm caches), %d rounds, wall time per cycle: bare %.2f us, in the runtime %.2f us\n", rounds,
              median(hot_bare) / 1e3, median(hot_rt) / 1e3);
  std::printf("  ratio           %8.3f  median of the paired per-round ratios (goal <= 1.05); range %.3f..%.3f\n",
              median(hot_ratio), *std::min_element(hot_ratio.begin(), hot_ratio.end()),
              *std::max_element(hot_ratio.begin(), hot_ratio.end()));
  std::printf("  at a 1 ms period (cold cache after each sleep; noisier):\n");
  std::printf("  %d rounds of %.1f s each, alternating; per-round averages:\n", rounds, round_s);
  for (int r = 0; r < rounds; ++r) {
    std::printf("    round %d: bare %7.2f us, in the runtime %7.2f us, ratio %.3f\n", r + 1,
                bare_avg[static_cast<size_t>(r)] / 1e3, rt_avg[static_cast<size_t>(r)] / 1e3,
                rt_avg[static_cast<size_t>(r)] / bare_avg[static_cast<size_t>(r)]);
  }
  std::printf("  bare executor   %8.2f us per cycle (median of rounds, %llu cycles)\n", median(bare_avg) / 1e3,
              static_cast<unsigned long long>(bare_cycles));
  std::printf("  in the runtime  %8.2f us per cycle (median of rounds, %llu cycles)\n", median(rt_avg) / 1e3,
              static_cast<unsigned long long>(rt_cycles));
  std::vector<double> ratios;
  for (size_t r = 0; r < rt_avg.size(); ++r) ratios.push_back(rt_avg[r] / bare_avg[r]);
  std::printf("  ratio           %8.3f  median of the paired per-round ratios (goal <= 1.05)\n",
              median(ratios));
  std::printf("                  %8.3f  ratio of the quietest rounds (min over min), %.3f ratio of the medians\n",
              *std::min_element(rt_avg.begin(), rt_avg.end()) / *std::min_element(bare_avg.begin(), bare_avg.end()),
              median(rt_avg) / median(bare_avg));

  // ---- 2. hot swap --------------------------------------------------------
  sched::LoadReport report;
  auto rt = sched::Runtime::load(*cfg.config, {}, report);
  if (!rt || !rt->start().ok()) {
    std::fputs(report.render().c_str(), stderr);
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto* st = static_cast<const sched::CycleStats*>(rt->image().task_stats(0));
  std::vector<double> request_to_cycle;
  const uint64_t skipped_before = st->skipped_releases();
  const uint64_t overruns_before = st->overruns();
  for (int i = 0; i < swaps; ++i) {
    const int64_t t0 = kernel_rt::monotonic_now_ns();
    auto r = rt->swap("big", i % 2 ? src : src_b, "big.fbd");
    if (!r) {
      std::fprintf(stderr, "swap %d failed: %s\n", i, r.error().c_str());
      return 1;
    }
    const int64_t applied = rt->image().task_info(0).last_swap_ns.load();
    request_to_cycle.push_back(static_cast<double>(applied - t0) / 1e6);
    rt->reap();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  rt->stop();
  const uint64_t swap_overruns = rt->image().task_info(0).swap_overruns.load();
  std::printf("\n-- hot swap of the %u-block task at 1 ms, %d swaps --\n", compiled.image->header().n_instr,
              swaps);
  std::printf("  request -> first cycle on new code: median %.2f ms, p99 %.2f ms, max %.2f ms "
              "(= %.1f periods at the median; compile and verify dominate)\n",
              median(request_to_cycle), percentile(request_to_cycle, 0.99),
              percentile(request_to_cycle, 1.0), median(request_to_cycle));
  std::printf("  releases missed because of a swap: %llu (goal 0)\n",
              static_cast<unsigned long long>(swap_overruns));
  std::printf("  all overruns during the swaps: %llu, releases skipped: %llu (the machine's noise included)\n",
              static_cast<unsigned long long>(st->overruns() - overruns_before),
              static_cast<unsigned long long>(st->skipped_releases() - skipped_before));
  std::printf("  task cycles %llu, swaps applied %llu\n", static_cast<unsigned long long>(st->cycles()),
              static_cast<unsigned long long>(rt->image().task_info(0).swaps.load()));
  return 0;
}
