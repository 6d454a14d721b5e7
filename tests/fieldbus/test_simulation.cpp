// The bus simulation: deterministic for a seed, it never sees a periodic delay
// beyond what the planner claims on a feasible design, and it shows the plan
// break when a non-RT packet is too long.
#include <gtest/gtest.h>

#include <random>

#include "fieldbus/planner.h"
#include "fieldbus/sim_report.h"
#include "fieldbus/simulation.h"

namespace rtplc::fieldbus {
namespace {

constexpr Nanos us = 1'000;
constexpr Nanos ms = 1'000'000;


SimResult run(const Design& d, const Plan& p, Nanos duration, uint64_t seed) {
  SimOptions o;
  o.duration = duration;
  o.seed = seed;
  auto r = simulate(d, p, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error());
  return r.ok() ? *r : SimResult{};
}

TEST(FieldbusSimulation, the_worked_example_holds) {
  const Design d = worked_example();
  const Plan p = plan(d);
  ASSERT_TRUE(p.feasible);
  const SimResult r = run(d, p, 10 * 1000 * ms, 1);
  EXPECT_EQ(r.samples, 2 * (2000 + 500));  // 10 s: L1 2000 samplings, L2 500, two packets each
  EXPECT_EQ(r.lost_samples, 0);
  EXPECT_EQ(r.vacant_samplings, 0);
  EXPECT_EQ(r.late_packets, 0);
  EXPECT_LE(r.periodic.max, p.transfer_bound);
  EXPECT_GT(r.nonrt_packets, 0);
  EXPECT_GT(r.realtime.count, 0);
  EXPECT_TRUE(simulation_holds(p, r));
}

TEST(FieldbusSimulation, is_deterministic_for_a_seed) {
  Design d = worked_example();
  d.nonrt_rate = 300;  // Poisson non-RT, so the seed matters twice
  const Plan p = plan(d);
  const SimResult a = run(d, p, 2000 * ms, 7);
  const SimResult b = run(d, p, 2000 * ms, 7);
  const SimResult c = run(d, p, 2000 * ms, 8);
  EXPECT_EQ(a.periodic.max, b.periodic.max);
  EXPECT_EQ(a.realtime.p99, b.realtime.p99);
  EXPECT_EQ(a.nonrt.count, b.nonrt.count);
  EXPECT_EQ(a.nonrt.max, b.nonrt.max);
  EXPECT_NE(a.nonrt.count, c.nonrt.count);
}

TEST(FieldbusSimulation, a_non_rt_packet_longer_than_the_frame_slack_breaks_the_plan) {
  Design d = worked_example();
  d.nonrt_packet = 5 * ms;  // T_1 - periodic part is 4.1ms
  const Plan p = plan(d);
  EXPECT_FALSE(p.feasible);
  const SimResult r = run(d, p, 10 * 1000 * ms, 1);
  EXPECT_GT(r.late_packets, 0);
  EXPECT_GT(r.lost_samples, 0);
  EXPECT_GT(r.vacant_samplings, 0);
  EXPECT_FALSE(simulation_holds(p, r));
}

TEST(FieldbusSimulation, refuses_a_server_that_costs_nothing) {
  Design d = worked_example();
  d.server_overhead = 0;
  EXPECT_FALSE(simulate(d, plan(d), SimOptions{}).ok());
}

// The property: on random feasible designs (seeded, bounded count), the worst
// periodic transfer delay seen stays within W and every loop's worst delay
// within its D_i bound, with no lost sample and no vacant sampling.
TEST(FieldbusSimulation, never_exceeds_the_planner_bound_on_random_designs) {
  std::mt19937_64 rng(4242);
  auto pick = [&](int64_t lo, int64_t hi) {
    return lo + static_cast<int64_t>(rng() % static_cast<uint64_t>(hi - lo + 1));
  };
  int feasible = 0;
  for (int trial = 0; trial < 2000 && feasible < 60; ++trial) {
    Design d;
    d.nodes = static_cast<int>(pick(4, 30));
    d.server_overhead = pick(5, 60) * us;
    d.periodic_packet = pick(20, 300) * us;
    d.rt_queues = static_cast<int>(pick(0, 4));
    d.rt_packet = pick(20, 300) * us;
    d.rt_rate = static_cast<double>(pick(0, 400));
    d.nonrt_rate = rng() % 2 ? -1 : static_cast<double>(pick(10, 2000));
    d.access = rng() % 2 ? Access::kPolling : Access::kTokenPassing;
    const int loops = static_cast<int>(pick(1, 6));
    const Nanos base = pick(2, 20) * ms;
    d.loops.push_back({"base", base, std::nullopt, -1, -1, {}});
    for (int i = 1; i < loops; ++i) {
      if (rng() % 3 == 0) {
        d.loops.push_back({"f" + std::to_string(i), base << pick(0, 3), std::nullopt, -1, -1, {}});
      } else {
        d.loops.push_back(
            {"m" + std::to_string(i), std::nullopt, pick(2 * base / ms, 200) * ms, -1, -1, {}});
      }
    }
    if (rng() % 2) d.nonrt_packet = pick(20, 2000) * us;
    const Plan p = plan(d);
    if (!p.feasible) continue;
    ++feasible;
    const SimResult r = run(d, p, 3000 * ms, static_cast<uint64_t>(trial));
    ASSERT_LE(r.periodic.max, p.transfer_bound) << "trial " << trial;
    for (size_t i = 0; i < r.loops.size(); ++i) {
      ASSERT_LE(r.loops[i].worst_delay, p.loops[i].delay_bound)
          << "trial " << trial << " loop " << i;
    }
    ASSERT_EQ(r.lost_samples, 0) << "trial " << trial;
    ASSERT_EQ(r.vacant_samplings, 0) << "trial " << trial;
  }
  EXPECT_GE(feasible, 60);  // the generator must keep producing designs worth checking
}

}  // namespace
}  // namespace rtplc::fieldbus
