// P-invariants by the Farkas algorithm and the structural bounds they give.
#include <gtest/gtest.h>

#include <algorithm>

#include "lang/petri/generators.h"
#include "lang/petri/invariants.h"
#include "tests/petri/test_support.h"

namespace rtplc::petri {
namespace {

bool is_invariant(const Net& net, const PInvariant& y) {
  const IntMatrix b = net.incidence();
  for (size_t t = 0; t < b.cols(); ++t) {
    int64_t s = 0;
    for (size_t p = 0; p < b.rows(); ++p) s += y.weights[p] * b(p, t);
    if (s != 0) return false;
  }
  return true;
}

std::vector<std::string> texts(const Net& net, const InvariantResult& r) {
  std::vector<std::string> v;
  for (const PInvariant& y : r.invariants) v.push_back(invariant_text(net, y));
  std::sort(v.begin(), v.end());
  return v;
}

TEST(Invariants, deadlock_net_has_its_four_token_loops) {
  const Net net = testing::deadlock_net();
  const InvariantResult r = p_invariants(net);
  EXPECT_TRUE(r.complete);
  EXPECT_TRUE(r.covered);
  EXPECT_EQ(texts(net, r), (std::vector<std::string>{"A0 + A1 + A2 = 1", "A1 + A2 + B2 + R1 = 1",
                                                     "A2 + B1 + B2 + R2 = 1", "B0 + B1 + B2 = 1"}));
  for (const PInvariant& y : r.invariants) EXPECT_TRUE(is_invariant(net, y));
}

TEST(Invariants, kanban_has_one_invariant_per_station_and_two_across_the_synchronised_ones) {
  // Stations 2 and 3 take and return their cards together, so each one's card
  // place also balances the other's machine.
  const Net net = kanban(3);
  const InvariantResult r = p_invariants(net);
  EXPECT_EQ(texts(net, r), (std::vector<std::string>{
                               "P2 + Pm3 + Pback3 + Pout3 = 3", "Pm1 + Pback1 + Pout1 + P1 = 3",
                               "Pm2 + Pback2 + Pout2 + P2 = 3", "Pm2 + Pback2 + Pout2 + P3 = 3",
                               "Pm3 + Pback3 + Pout3 + P3 = 3", "Pm4 + Pback4 + Pout4 + P4 = 3"}));
  for (const auto& b : structural_bounds(net, r)) EXPECT_EQ(b, 3u);
}

TEST(Invariants, weights_other_than_one) {
  // t: 2 a -> b; u: b -> 2 a. Invariant a + 2 b.
  Net n;
  const PlaceId a = n.add_place("a", 4).value(), b = n.add_place("b").value();
  const TransitionId t = n.add_transition("t").value(), u = n.add_transition("u").value();
  n.add_input(a, t, 2);
  n.add_output(t, b);
  n.add_input(b, u);
  n.add_output(u, a, 2);
  const InvariantResult r = p_invariants(n);
  ASSERT_EQ(r.invariants.size(), 1u);
  EXPECT_EQ(invariant_text(n, r.invariants[0]), "a + 2*b = 4");
  const auto bounds = structural_bounds(n, r);
  EXPECT_EQ(bounds[a], 4u);
  EXPECT_EQ(bounds[b], 2u);
}

TEST(Invariants, unbounded_place_is_not_covered) {
  const Net net = testing::producer_net();
  const InvariantResult r = p_invariants(net);
  EXPECT_FALSE(r.covered);
  EXPECT_FALSE(structural_bounds(net, r)[*net.find_place("buffer")].has_value());
}

TEST(Invariants, philosophers_10_has_twenty) {
  const Net net = philosophers(10);
  const InvariantResult r = p_invariants(net);
  EXPECT_TRUE(r.covered);
  EXPECT_EQ(r.invariants.size(), 20u);
  for (const PInvariant& y : r.invariants) {
    EXPECT_TRUE(is_invariant(net, y));
    EXPECT_EQ(y.token_sum, 1);
  }
}

}  // namespace
}  // namespace rtplc::petri
