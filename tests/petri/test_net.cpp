// The net model: B-, B+, B, firing rules 1-3 and the state equation, with the
// spec's sub-PN of step S1 (petri-sfc.md, "Sub-PN of step S1").
#include <gtest/gtest.h>

#include "lang/petri/net.h"
#include "tests/petri/test_support.h"

namespace rtplc::petri {
namespace {

const IntMatrix kBs1 = IntMatrix::from_rows({
    {1, -1, 0, 0, 0, 0, 0, 0, 0, 0},   // L1
    {-1, 1, 0, 0, 0, 0, 0, 0, 0, 0},   // L0
    {0, 0, 1, -1, 0, 0, 0, 0, 0, 0},   // V11
    {0, 0, -1, 1, 0, 0, 0, 0, 0, 0},   // V10
    {0, 0, 0, 0, 1, 0, -1, 0, 0, 0},   // Z12
    {0, 0, 0, 0, -1, 1, 1, -1, 0, 0},  // Z11
    {0, 0, 0, 0, 0, -1, 0, 1, 0, 0},   // Z10
    {0, 0, 0, 0, 0, 0, 0, 0, 1, -1},   // D21
    {0, 0, 0, 0, 0, 0, 0, 0, -1, 1},   // D20
});

Net sub_pn_s1() {
  auto net = Net::from_incidence(
      kBs1, {"L1", "L0", "V11", "V10", "Z12", "Z11", "Z10", "D21", "D20"},
      {"tL0", "tL1", "tv10", "tv11", "tz10", "tz11", "tz12", "tz13", "tD20", "tD21"},
      {1, 0, 0, 1, 0, 0, 1, 1, 0});
  EXPECT_TRUE(net.ok()) << net.error();
  return std::move(net.value());
}

TEST(Net, incidence_is_output_minus_input) {
  const Net n = testing::deadlock_net();
  const IntMatrix bm = n.input_matrix(), bp = n.output_matrix(), b = n.incidence();
  ASSERT_EQ(b.rows(), 8u);
  ASSERT_EQ(b.cols(), 6u);
  for (size_t i = 0; i < b.rows(); ++i) {
    for (size_t j = 0; j < b.cols(); ++j) EXPECT_EQ(b(i, j), bp(i, j) - bm(i, j));
  }
  // takeR1_A consumes A0 and R1 and produces A1.
  EXPECT_EQ(bm(*n.find_place("R1"), *n.find_transition("takeR1_A")), 1);
  EXPECT_EQ(b(*n.find_place("A1"), *n.find_transition("takeR1_A")), 1);
}

TEST(Net, read_arc_needs_tokens_but_leaves_b_unchanged) {
  const Net n = testing::producer_net();
  const PlaceId ready = *n.find_place("ready");
  const TransitionId produce = *n.find_transition("produce");
  EXPECT_EQ(n.incidence()(ready, produce), 0);
  EXPECT_EQ(n.pre(ready, produce), 1u);
  Marking m = n.initial_marking();
  m[ready] = 0;
  EXPECT_FALSE(n.enabled(m, produce));
}

TEST(Net, rebuilds_the_spec_sub_pn_of_step_s1) {
  const Net n = sub_pn_s1();
  EXPECT_EQ(n.incidence(), kBs1);
}

TEST(Net, state_equation_reproduces_the_spec_trace_of_step_s1) {
  const Net n = sub_pn_s1();
  const Marking x0 = n.initial_marking();
  // tL1 and tv10 together: lamp off, valve 1 open.
  auto x1 = state_equation_step(n, x0, {0, 1, 1, 0, 0, 0, 0, 0, 0, 0});
  ASSERT_TRUE(x1.ok()) << x1.error();
  EXPECT_EQ(*x1, (Marking{0, 1, 1, 0, 0, 0, 1, 1, 0}));
  auto x2 = state_equation_step(n, *x1, {0, 0, 0, 0, 0, 1, 0, 0, 0, 0});  // tz11: level N
  ASSERT_TRUE(x2.ok()) << x2.error();
  EXPECT_EQ(*x2, (Marking{0, 1, 1, 0, 0, 1, 0, 1, 0}));
  auto x3 = state_equation_step(n, *x2, {0, 0, 0, 0, 1, 0, 0, 0, 0, 1});  // tz10, tD21: H, LS2 off
  ASSERT_TRUE(x3.ok()) << x3.error();
  EXPECT_EQ(*x3, (Marking{0, 1, 1, 0, 1, 0, 0, 0, 1}));
  // The same trace as single firings (rule 3: order does not matter).
  auto seq = fire_sequence(n, x0, {2, 1, 5, 9, 4});
  ASSERT_TRUE(seq.ok()) << seq.error();
  EXPECT_EQ(*seq, *x3);
}

TEST(Net, state_equation_refuses_a_transition_that_is_not_enabled) {
  const Net n = sub_pn_s1();
  auto x =
      state_equation_step(n, n.initial_marking(), {1, 0, 0, 0, 0, 0, 0, 0, 0, 0});  // tL0 needs L0
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().find("tL0"), std::string::npos);
}

TEST(Net, state_equation_reports_conflicting_transitions) {
  const Net n = testing::deadlock_net();
  // takeR1_A and takeR1_B both want R1: each is enabled alone after the right
  // prefix, but not together.
  Marking m = n.initial_marking();
  m[*n.find_place("B0")] = 0;
  m[*n.find_place("B1")] = 1;
  std::vector<int> f(n.transition_count(), 0);
  f[*n.find_transition("takeR1_A")] = 1;
  f[*n.find_transition("takeR1_B")] = 1;
  auto x = state_equation_step(n, m, f);
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().find("conflict over place R1"), std::string::npos) << x.error();
}

TEST(Net, refuses_a_repeated_id) {
  Net n;
  ASSERT_TRUE(n.add_place("p").ok());
  EXPECT_FALSE(n.add_place("p").ok());
  EXPECT_FALSE(n.add_transition("p").ok());
}

}  // namespace
}  // namespace rtplc::petri
