// The planner: the worked example of docs/fieldbus.md, each failing condition
// with its exact shortfall, and the window schedule's invariants.
#include <gtest/gtest.h>

#include <random>

#include "fieldbus/planner.h"

namespace rtplc::fieldbus {
namespace {

constexpr Nanos us = 1'000;
constexpr Nanos ms = 1'000'000;


const Failure* find(const Plan& p, Condition c) {
  for (const Failure& f : p.failures) {
    if (f.condition == c) return &f;
  }
  return nullptr;
}

TEST(FieldbusPlanner, reproduces_the_worked_example_of_the_docs) {
  const Plan p = plan(worked_example());
  ASSERT_TRUE(p.feasible) << (p.failures.empty() ? "" : p.failures[0].message);
  EXPECT_EQ(p.t1, 5 * ms);
  EXPECT_EQ(p.server_round, 200 * us);
  ASSERT_EQ(p.loops.size(), 2u);
  EXPECT_EQ(p.loops[0].period, 5 * ms);
  EXPECT_EQ(p.loops[0].offset, 0);
  // (2^k + 1) T_1 <= 25ms gives k = 2: T_2 = 20ms.
  EXPECT_EQ(p.loops[1].period, 20 * ms);
  EXPECT_EQ(p.loops[1].offset, 0);
  EXPECT_EQ(p.hyperperiod, 4);
  EXPECT_EQ(p.frame_load, (std::vector<int>{4, 2, 2, 2}));
  EXPECT_EQ(p.gamma, 4);
  EXPECT_EQ(p.gamma_lower_bound, 4);
  EXPECT_EQ(p.periodic_part, 900 * us);  // 4 * 100 + 2 * 150 + 200
  EXPECT_EQ(p.ln_max, 585'714);          // 4100us / 7, rounded down to the nanosecond
  EXPECT_EQ(p.transfer_bound, 1'485'714);
  EXPECT_EQ(p.loops[0].delay_bound, 6'485'714);
  EXPECT_EQ(p.loops[1].delay_bound, 21'485'714);
  EXPECT_EQ(p.shortfall(), 0);
}

TEST(FieldbusPlanner, names_the_stability_shortfall_exactly) {
  Design d;
  d.nodes = 10;
  d.server_overhead = 50 * us;
  d.periodic_packet = 400 * us;
  d.rt_queues = 2;
  d.rt_packet = 150 * us;
  for (const char* n : {"A", "B", "C", "D", "E"}) d.loops.push_back({n, 2 * ms, {}, -1, -1, {}});
  const Plan p = plan(d);
  EXPECT_FALSE(p.feasible);
  EXPECT_EQ(p.gamma, 10);
  EXPECT_EQ(p.periodic_part, 4'800 * us);
  const Failure* f = find(p, Condition::kStability);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->shortfall, 2'800 * us);
  EXPECT_EQ(p.shortfall(), 2'800 * us);
  EXPECT_NE(f->message.find("exceeds T_1 = 2ms by 2.8ms"), std::string::npos) << f->message;
}

TEST(FieldbusPlanner, refuses_a_non_rt_packet_longer_than_ln_max) {
  Design d = worked_example();
  d.nonrt_packet = 600 * us;
  const Plan p = plan(d);
  EXPECT_FALSE(p.feasible);
  const Failure* f = find(p, Condition::kNonrtPacket);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->shortfall, 600 * us - 585'714);
  // At L_n max exactly it is fine.
  d.nonrt_packet = 585'714;
  EXPECT_TRUE(plan(d).feasible);
}

TEST(FieldbusPlanner, reports_a_loop_whose_delay_bound_cannot_be_met) {
  Design d = worked_example();
  d.loops.push_back({"fast", std::nullopt, 6 * ms, -1, -1, {}});
  const Plan p = plan(d);
  EXPECT_FALSE(p.feasible);
  const Failure* f = find(p, Condition::kC2);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->loop, "fast");
  // The added loop raises gamma to 6: W = L_n max + 6*100 + 300 + 200.
  EXPECT_EQ(p.gamma, 6);
  const Nanos ln = (5 * ms - 1'100 * us) / 5;
  EXPECT_EQ(p.ln_max, ln);
  EXPECT_EQ(f->shortfall, 5 * ms + ln + 1'100 * us - 6 * ms);
}

TEST(FieldbusPlanner, refuses_a_fixed_period_that_is_not_harmonic) {
  Design d = worked_example();
  d.loops.push_back({"odd", 7 * ms, {}, -1, -1, {}});
  const Plan p = plan(d);
  const Failure* f = find(p, Condition::kPeriod);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->loop, "odd");
  EXPECT_FALSE(p.feasible);
}

TEST(FieldbusPlanner, explains_more_windows_than_periodic_nodes) {
  Design d = worked_example();
  d.nodes = 4;
  d.loops = {
      {"a", 5 * ms, {}, -1, -1, {}}, {"b", 5 * ms, {}, -1, -1, {}}, {"c", 5 * ms, {}, -1, -1, {}}};
  const Plan p = plan(d);
  EXPECT_FALSE(p.feasible);
  EXPECT_EQ(p.gamma_lower_bound, 6);
  EXPECT_EQ(p.periodic_nodes, 4);
  const Failure* f = find(p, Condition::kWindows);
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->message.find("gamma <= N_p"), std::string::npos);
  EXPECT_NE(find(p, Condition::kNodeLoad), nullptr);
}

TEST(FieldbusPlanner, explains_a_frame_shorter_than_one_packet) {
  Design d = worked_example();
  d.frame = 50 * us;
  d.loops = {{"a", std::nullopt, 10 * ms, -1, -1, {}}};
  const Plan p = plan(d);
  const Failure* f = find(p, Condition::kFrame);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->shortfall, 50 * us);  // L_p = 100us against T_1 = 50us
  EXPECT_NE(f->message.find("shorter than one periodic packet"), std::string::npos);
}

TEST(FieldbusPlanner, explains_zero_nodes) {
  Design d = worked_example();
  d.nodes = 0;
  const Plan p = plan(d);
  EXPECT_FALSE(p.feasible);
  ASSERT_NE(find(p, Condition::kLink), nullptr);
  EXPECT_NE(find(p, Condition::kLink)->message.find("no nodes"), std::string::npos);
}

TEST(FieldbusPlanner, a_loop_with_both_ends_on_one_node_is_refused) {
  Design d = worked_example();
  d.loops[1].sensor_node = 3;
  d.loops[1].controller_node = 3;
  const Plan p = plan(d);
  const Failure* f = find(p, Condition::kNodeLoad);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->loop, "L2");
}

// Random harmonic designs on a link with a node for every loop end: the greedy
// must meet the lower bound 2 * ceil(sum 1/m_i), never put two packets of one
// node in a frame, and its frame loads must be what the offsets say.
TEST(FieldbusPlanner, window_schedule_meets_the_lower_bound_on_random_designs) {
  std::mt19937_64 rng(20240611);
  for (int trial = 0; trial < 200; ++trial) {
    Design d;
    d.nodes = kMaxNodes;
    d.server_overhead = 1 * us;
    d.periodic_packet = 10 * us;
    const int loops = 1 + static_cast<int>(rng() % 60);
    d.loops.push_back({"base", 1 * ms, {}, -1, -1, {}});
    for (int i = 1; i < loops; ++i) {
      d.loops.push_back({"l" + std::to_string(i),
                         std::nullopt,
                         static_cast<Nanos>(2 + rng() % 300) * ms,
                         -1,
                         -1,
                         {}});
    }
    const Plan p = plan(d);
    ASSERT_EQ(p.gamma, p.gamma_lower_bound) << "trial " << trial;
    std::vector<int> load(static_cast<size_t>(p.hyperperiod), 0);
    std::vector<std::vector<int>> per_node(static_cast<size_t>(d.nodes),
                                           std::vector<int>(load.size(), 0));
    for (const LoopPlan& l : p.loops) {
      ASSERT_GE(l.offset, 0);
      const int64_t m = l.period / p.t1;
      ASSERT_LT(l.offset, m);
      for (int64_t f = l.offset; f < p.hyperperiod; f += m) {
        load[static_cast<size_t>(f)] += 2;
        ASSERT_EQ(++per_node[static_cast<size_t>(l.sensor_node)][static_cast<size_t>(f)], 1);
        ASSERT_EQ(++per_node[static_cast<size_t>(l.controller_node)][static_cast<size_t>(f)], 1);
      }
      if (l.max_delay) {
        EXPECT_LE(l.period + p.t1, *l.max_delay);      // the rule that chose it
        EXPECT_GT(2 * l.period + p.t1, *l.max_delay);  // and the longest such period
      }
    }
    EXPECT_EQ(load, p.frame_load);
  }
}

}  // namespace
}  // namespace rtplc::fieldbus
