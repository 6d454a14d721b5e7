// Executor throughput on a generated 10,000-block program against hand-written
// C++ doing the same arithmetic on plain arrays, in the same binary and run; and
// the compile time of that program. Prints ns per block for both, the ratio,
// and the compile time (targets: ratio <= 2.0, compile <= 50 ms); and the cost
// of the status lane (blocks/status.h) against the same executor without it
// (target: at most 5% slower while the inputs are good).
//
//   build/release/bench/bench_executor            (scripts/bench executor runs it)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "bench/support/loop_program.h"
#include "blocks/executor.h"
#include "blocks/status.h"
#include "lang/compiler.h"

namespace {

using namespace rtplc;

constexpr size_t kLoops = 715;  // 715 x 14 = 10,010 blocks
constexpr double kDt = 0.001;

// ---- the reference: the same loops written by hand over arrays ----------------
struct Reference {
  explicit Reference(size_t loops)
      : n(loops), sp(n, 50), en(n, 1), meas(n, 0), integ(n, 0), dprev(n, 0), dprimed(n, 0),
        plant(n, 0), tcount(n, 0), count(n, 0), edge(n, 0), mv(n, 0), alarm(n, 0) {}

  // Same formulas and coefficients as the blocks (docs/blocks.md).
  void cycle() {
    const double a_meas = kDt / (0.5 + kDt), a_plant = kDt / (3 + kDt);
    const double kp = 2, ki = kDt / 5, kd = 0.2 / kDt;
    const double n_timer = std::ceil(0.05 / kDt - 1e-9);
    for (size_t i = 0; i < n; ++i) {
      const double m = meas[i] + a_meas * (plant[i] - meas[i]);
      meas[i] = m;
      const double e = sp[i] - m;
      const double in = integ[i] + e * ki;
      integ[i] = in;
      const double pi = kp * (e + in);
      const double d = dprimed[i] != 0 ? (m - dprev[i]) * kd : 0.0;
      dprev[i] = m;
      dprimed[i] = 1;
      const double u = std::min(std::max(pi - d, 0.0), 100.0);
      plant[i] = plant[i] + a_plant * (u - plant[i]);
      mv[i] = u;
      const bool enabled = en[i] != 0;
      bool timer = false;
      if (enabled) {
        timer = tcount[i] >= n_timer;
        if (tcount[i] < n_timer) tcount[i] += 1;
      } else {
        tcount[i] = 0;
      }
      if (!enabled) {
        count[i] = 0;
      } else if (timer && !edge[i]) {
        count[i] += 1;
      }
      edge[i] = timer;
      alarm[i] = count[i] >= 10 ? 1.0 : 0.0;
    }
  }

  size_t n;
  std::vector<double> sp, en, meas, integ, dprev, dprimed, plant, tcount, count;
  std::vector<uint8_t> edge;
  std::vector<double> mv, alarm;
};

struct Fixture {
  Fixture() {
    source = bench::loop_program(static_cast<int>(kLoops), kDt);
    auto r = lang::compile_source(source);
    if (!r.ok()) {
      std::fputs(r.diags.render("bench", source).c_str(), stderr);
      std::abort();
    }
    image = std::move(*r.image);
    arena.resize_for(image);
    for (const Binding& b : image.bindings()) {
      if (b.dir == BindingDir::kSetpoint) arena.io_in[b.io_index] = b.init;
      const std::string label = image.str(b.label);
      if (label.rfind("MV", 0) == 0) mv_index[std::stoi(label.substr(2))] = b.io_index;
      if (label.rfind("ALM", 0) == 0) alarm_index[std::stoi(label.substr(3))] = b.io_index;
    }
  }
  std::string source;
  TaskImage image;
  TaskArena arena;
  std::map<int, uint32_t> mv_index, alarm_index;
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void run_executor(benchmark::State& state, ExecutorBody body) {
  Fixture& f = fixture();
  const ExecContext ctx = make_context(f.image, f.arena);
  for (auto _ : state) {
    execute_cycle_on(body, ctx);
    benchmark::ClobberMemory();
  }
  state.counters["blocks"] = static_cast<double>(f.image.header().n_instr);
  state.counters["ns_per_block"] = benchmark::Counter(
      static_cast<double>(f.image.header().n_instr) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The executor with the status lane as a task runs it (sched/task.cpp): every
// cycle asks needs_pass and runs propagate_status when it says so. `good`:
// every input good, the task's usual state (a scan of the input statuses);
// otherwise one input stays stale, so the whole pass runs every cycle (the
// worst case: a loop of the plant whose measurement is lost).
void run_with_status(benchmark::State& state, bool all_good) {
  Fixture& f = fixture();
  const ExecContext ctx = make_context(f.image, f.arena);
  const ExecutorBody body =
      std::strcmp(executor_variant(), "avx2") == 0 ? ExecutorBody::kAvx2 : ExecutorBody::kBaseline;
  StatusLane lane(f.image);
  std::fill(lane.in.begin(), lane.in.end(), static_cast<uint8_t>(Lane::kGood));
  if (!all_good && !lane.in.empty()) lane.set_in(0, static_cast<uint8_t>(Lane::kUncertain));
  uint64_t passes = 0;
  for (auto _ : state) {
    execute_cycle_on(body, ctx);
    if (!all_good) lane.set_in(0, static_cast<uint8_t>(Lane::kUncertain));  // as its reader would
    if (lane.needs_pass(f.arena.total_errors)) {
      propagate_status(f.image, f.arena, lane);
      ++passes;
    }
    benchmark::ClobberMemory();
  }
  state.counters["passes"] = static_cast<double>(passes);
}
void BM_ExecutorStatusGood(benchmark::State& state) { run_with_status(state, true); }
void BM_ExecutorStatusPass(benchmark::State& state) { run_with_status(state, false); }

void BM_Reference(benchmark::State& state) {
  Reference ref(kLoops);
  for (auto _ : state) {
    ref.cycle();
    benchmark::ClobberMemory();
  }
  const double blocks = static_cast<double>(kLoops) * bench::kBlocksPerLoop;
  state.counters["blocks"] = blocks;
  state.counters["ns_per_block"] = benchmark::Counter(
      blocks * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_Compile(benchmark::State& state) {
  const std::string& src = fixture().source;
  for (auto _ : state) {
    auto r = lang::compile_source(src);
    benchmark::DoNotOptimize(r.image);
  }
}

// The body execute_cycle picks on this CPU (AVX2 where present) ...
void BM_Executor(benchmark::State& state) {
  run_executor(state, std::strcmp(executor_variant(), "avx2") == 0 ? ExecutorBody::kAvx2
                                                                   : ExecutorBody::kBaseline);
}
// ... and the baseline x86-64 body, for machines without AVX2.
void BM_ExecutorBaseline(benchmark::State& state) { run_executor(state, ExecutorBody::kBaseline); }

BENCHMARK(BM_Executor)->Unit(benchmark::kMicrosecond)->MinTime(0.3);
BENCHMARK(BM_ExecutorBaseline)->Unit(benchmark::kMicrosecond)->MinTime(0.3);
BENCHMARK(BM_ExecutorStatusGood)->Unit(benchmark::kMicrosecond)->MinTime(0.3);
BENCHMARK(BM_ExecutorStatusPass)->Unit(benchmark::kMicrosecond)->MinTime(0.3);
BENCHMARK(BM_Reference)->Unit(benchmark::kMicrosecond)->MinTime(0.3);
BENCHMARK(BM_Compile)->Unit(benchmark::kMillisecond)->MinTime(1.0);

// The two implementations must agree, or the comparison means nothing.
bool same_results(ExecutorBody body) {
  Fixture f;  // fresh arena
  Reference ref(kLoops);
  const ExecContext ctx = make_context(f.image, f.arena);
  for (int c = 0; c < 2000; ++c) {
    execute_cycle_on(body, ctx);
    ref.cycle();
  }
  for (size_t i = 0; i < kLoops; ++i) {
    const int li = static_cast<int>(i);
    const double a = f.arena.io_out[f.mv_index[li]], b = ref.mv[i];
    if (std::memcmp(&a, &b, sizeof a) != 0 || f.arena.io_out[f.alarm_index[li]] != ref.alarm[i]) {
      std::fprintf(stderr, "loop %zu differs: executor %.17g, reference %.17g\n", i, a, b);
      return false;
    }
  }
  return true;
}

// Collects the median of each benchmark's repetitions.
class Collector : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name != "median") continue;
      const std::string name = r.run_name.function_name;
      ns_per_iter[name] = r.GetAdjustedRealTime() * (r.time_unit == benchmark::kMillisecond ? 1e6
                                                     : r.time_unit == benchmark::kMicrosecond ? 1e3
                                                                                              : 1.0);
    }
  }
  std::map<std::string, double> ns_per_iter;
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> args(argv, argv + argc);
  bool has_reps = false;
  for (char* a : args) has_reps |= std::strncmp(a, "--benchmark_repetitions", 23) == 0;
  std::string reps = "--benchmark_repetitions=9";
  if (!has_reps) args.push_back(reps.data());
  // Repetitions of the executor and the reference alternate in random order, so
  // drifts of the machine (frequency, a neighbour's load) hit both alike.
  std::string interleave = "--benchmark_enable_random_interleaving=true";
  args.push_back(interleave.data());
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  if (!same_results(ExecutorBody::kBaseline) || !same_results(ExecutorBody::kAvx2)) {
    std::fprintf(stderr, "executor and reference disagree; figures would be meaningless\n");
    return 1;
  }
  Collector rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  const double blocks = static_cast<double>(fixture().image.header().n_instr);
  const double exec = rep.ns_per_iter["BM_Executor"] / blocks;
  const double base = rep.ns_per_iter["BM_ExecutorBaseline"] / blocks;
  const double ref = rep.ns_per_iter["BM_Reference"] / blocks;
  const double compile_ms = rep.ns_per_iter["BM_Compile"] / 1e6;
  const double st_good = rep.ns_per_iter["BM_ExecutorStatusGood"] / blocks;
  const double st_pass = rep.ns_per_iter["BM_ExecutorStatusPass"] / blocks;
  std::printf("\n== rtplc executor vs hand-written C++ (%zu loops, %.0f blocks, %u runs, medians of 9, interleaved) ==\n",
              kLoops, blocks, fixture().image.header().n_runs);
  std::printf("  executor        %7.3f ns/block  (%8.1f us per cycle, %s body)\n", exec,
              exec * blocks / 1e3, executor_variant());
  std::printf("  hand-written    %7.3f ns/block  (%8.1f us per cycle, -O2)\n", ref, ref * blocks / 1e3);
  std::printf("  ratio           %7.2f           (target <= 2.00)\n", exec / ref);
  if (std::strcmp(executor_variant(), "baseline") != 0) {
    std::printf("  baseline body   %7.3f ns/block  ratio %.2f (what a CPU without AVX2 gets)\n", base,
                base / ref);
  }
  std::printf("  status lane     %7.3f ns/block  ratio %.3f to status off (inputs good; target <= 1.05)\n",
              st_good, st_good / exec);
  std::printf("                  %7.3f ns/block  ratio %.3f to status off (an input stale: the pass every cycle)\n",
              st_pass, st_pass / exec);
  std::printf("  compile         %7.2f ms for the %.0f-block file (target <= 50 ms)\n", compile_ms, blocks);
  std::printf("  results         bit-identical to the reference after 2000 cycles (both bodies)\n");
  return 0;
}
