// bench_fieldbus: how long the fieldbus planner takes for 1,000 loops on one bus,
// and how long the simulation takes for 10 minutes of bus time (fieldbus issue,
// "Benchmark"; docs/fieldbus.md). A plain main like bench_s7: each figure is the
// best of a few runs of the same work, and the reference beside it is the
// worked example (2 loops) planned and simulated the same way, so a reader sees
// how the cost grows with the design.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>

#include "fieldbus/planner.h"
#include "fieldbus/simulation.h"

using namespace rtplc::fieldbus;

namespace {

constexpr Nanos us = 1'000;
constexpr Nanos ms = 1'000'000;

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// 1,000 loops on a 127-node bus: one 2ms loop on the last two nodes sets T_1;
// the others, spread over nodes 0..124, give delay bounds between 120ms and 2s,
// so the planner chooses periods of 32 to 512 frames.
Design thousand_loops() {
  Design d;
  d.nodes = kMaxNodes;
  d.server_overhead = 2 * us;
  d.periodic_packet = 20 * us;
  d.rt_queues = 4;
  d.rt_packet = 20 * us;
  d.rt_rate = 50;
  std::mt19937_64 rng(1000);
  d.loops.push_back({"base", 2 * ms, std::nullopt, kMaxNodes - 2, kMaxNodes - 1, {}});
  for (int i = 1; i < 1000; ++i) {
    d.loops.push_back({"loop" + std::to_string(i),
                       std::nullopt,
                       static_cast<Nanos>(120 + rng() % 1880) * ms,
                       (2 * i) % 125,
                       (2 * i + 1) % 125,
                       {}});
  }
  return d;
}


// Best wall time of `runs` calls of f.
template <typename F>
double best_of(int runs, F&& f) {
  double best = 1e30;
  for (int i = 0; i < runs; ++i) {
    const double t0 = now_s();
    f();
    best = std::min(best, now_s() - t0);
  }
  return best;
}

void report(const char* name, const Design& d) {
  Plan p;
  const double plan_s = best_of(20, [&] { p = plan(d); });
  std::printf("%s: %zu loops, %d nodes: %s, T_1 %s, gamma %d (lower bound %d), L_n max %s\n", name,
              d.loops.size(), d.nodes, p.feasible ? "feasible" : "INFEASIBLE",
              format_time(p.t1).c_str(), p.gamma, p.gamma_lower_bound,
              format_time(p.ln_max).c_str());
  for (size_t i = 0; i < p.failures.size() && i < 5; ++i) {
    std::printf("  fails %s: %s\n", to_string(p.failures[i].condition),
                p.failures[i].message.c_str());
  }
  std::printf("  planning                      %10.1f us\n", plan_s * 1e6);
  SimOptions opt;
  opt.duration = 600 * kNanosPerSecond;
  SimResult r;
  const double sim_s = best_of(3, [&] {
    auto res = simulate(d, p, opt);
    if (res) r = *res;
  });
  std::printf("  simulating 10 min of bus time %10.3f s  (%.0fx faster than the bus)\n", sim_s,
              600 / sim_s);
  std::printf(
      "  simulated: %lld periodic packets, worst %s (bound W %s), lost %lld, vacant %lld, "
      "%lld non-RT packets\n",
      static_cast<long long>(r.periodic.count), format_time(r.periodic.max).c_str(),
      format_time(p.transfer_bound).c_str(), static_cast<long long>(r.lost_samples),
      static_cast<long long>(r.vacant_samplings), static_cast<long long>(r.nonrt_packets));
}

}  // namespace

int main() {
  report("reference (worked example)", worked_example());
  report("1,000 loops on one bus", thousand_loops());
  return 0;
}
