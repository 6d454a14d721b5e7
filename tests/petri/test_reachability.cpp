// Reachability over packed markings: hand-made nets with known graphs, dead markings
// with their shortest sequences, unboundedness with its pumping sequence, and the
// MCC models' exact figures (issue items 3 and 4).
#include <gtest/gtest.h>

#include "lang/petri/generators.h"
#include "lang/petri/invariants.h"
#include "lang/petri/reachability.h"
#include "lang/petri/reference_bfs.h"
#include "tests/petri/test_support.h"

namespace rtplc::petri {
namespace {

ReachabilityResult explore_with_bounds(const Net& net, ExploreOptions opt = {}) {
  opt.place_bounds = structural_bounds(net, p_invariants(net));
  return explore(net, opt);
}

std::vector<std::string> names(const Net& net, const std::vector<TransitionId>& seq) {
  std::vector<std::string> v;
  for (TransitionId t : seq) v.push_back(net.transition(t).id);
  return v;
}

TEST(Reachability, finds_the_deadlock_and_the_shortest_sequence_into_it) {
  const Net net = testing::deadlock_net();
  const ReachabilityResult r = explore_with_bounds(net);
  ASSERT_TRUE(r.exact());
  EXPECT_EQ(r.markings, 6u);
  EXPECT_EQ(r.edges, 8u);
  ASSERT_EQ(r.dead_markings, 1u);
  ASSERT_EQ(r.dead_examples.size(), 1u);
  EXPECT_EQ(marking_text(net, r.dead_examples[0].marking), "A1, B1");
  EXPECT_EQ(names(net, r.dead_examples[0].path),
            (std::vector<std::string>{"takeR1_A", "takeR2_B"}));
  EXPECT_TRUE(r.safe());
  for (bool f : r.fired) EXPECT_TRUE(f);
}

TEST(Reachability, shortest_sequence_is_shortest_when_a_longer_one_comes_first) {
  // t_long: a -> b, b -> c, c -> dead end needs 3 steps; t_short: a -> d (dead) in
  // one, but listed last so a depth-first search would find the long one first.
  Net n;
  const PlaceId a = n.add_place("a", 1).value(), b = n.add_place("b").value();
  const PlaceId c = n.add_place("c").value(), d = n.add_place("d").value(),
                e = n.add_place("e").value();
  auto arc = [&n](const std::string& id, PlaceId from, PlaceId to) {
    const TransitionId t = n.add_transition(id).value();
    n.add_input(from, t);
    n.add_output(t, to);
  };
  arc("ab", a, b);
  arc("bc", b, c);
  arc("ce", c, e);
  arc("ad", a, d);
  const ReachabilityResult r = explore_with_bounds(n);
  ASSERT_EQ(r.dead_markings, 2u);
  EXPECT_EQ(names(n, r.dead_examples[0].path), (std::vector<std::string>{"ad"}));
  EXPECT_EQ(names(n, r.dead_examples[1].path), (std::vector<std::string>{"ab", "bc", "ce"}));
}

TEST(Reachability, unbounded_net_is_reported_with_its_pumping_sequence) {
  const Net net = testing::producer_net();
  const ReachabilityResult r = explore_with_bounds(net);
  ASSERT_EQ(r.status, ExploreStatus::kUnbounded);
  ASSERT_TRUE(r.pump.has_value());
  EXPECT_TRUE(r.pump->prefix.empty());
  EXPECT_EQ(names(net, r.pump->cycle), (std::vector<std::string>{"produce"}));
  ASSERT_EQ(r.pump->growing.size(), 1u);
  EXPECT_EQ(net.place(r.pump->growing[0]).id, "buffer");
}

TEST(Reachability, pumping_sequence_after_a_prefix) {
  // start -> loop; then loop: x -> y, y -> x + token. Grows only after "go".
  Net n;
  const PlaceId start = n.add_place("start", 1).value(), x = n.add_place("x").value();
  const PlaceId y = n.add_place("y").value(), tok = n.add_place("tok").value();
  const TransitionId go = n.add_transition("go").value();
  n.add_input(start, go);
  n.add_output(go, x);
  const TransitionId t1 = n.add_transition("t1").value();
  n.add_input(x, t1);
  n.add_output(t1, y);
  const TransitionId t2 = n.add_transition("t2").value();
  n.add_input(y, t2);
  n.add_output(t2, x);
  n.add_output(t2, tok, 2);
  const ReachabilityResult r = explore_with_bounds(n);
  ASSERT_EQ(r.status, ExploreStatus::kUnbounded);
  EXPECT_EQ(names(n, r.pump->prefix), (std::vector<std::string>{"go"}));
  EXPECT_EQ(names(n, r.pump->cycle), (std::vector<std::string>{"t1", "t2"}));
  EXPECT_EQ(r.pump->end[tok] - r.pump->start[tok], 2u);
  auto end = fire_sequence(n, n.initial_marking(), {go, t1, t2});
  ASSERT_TRUE(end.ok());
  EXPECT_EQ(*end, r.pump->end);
}

TEST(Reachability, bounded_net_without_invariants_is_explored_exactly) {
  // A place no P-invariant covers (a sink filled at most 3 times) still ends.
  Net n;
  const PlaceId src = n.add_place("src", 3).value(), sink = n.add_place("sink").value();
  const TransitionId t = n.add_transition("drain").value();
  n.add_input(src, t);
  n.add_output(t, sink, 2);
  const ReachabilityResult r = explore_with_bounds(n);
  ASSERT_TRUE(r.exact());
  EXPECT_EQ(r.markings, 4u);
  EXPECT_EQ(r.max_tokens_in_place, 6u);
  EXPECT_FALSE(r.safe());
  EXPECT_EQ(r.dead_markings, 1u);
}

TEST(Reachability, stops_at_the_marking_limit) {
  ExploreOptions opt;
  opt.max_markings = 100;
  const ReachabilityResult r = explore_with_bounds(philosophers(6), opt);
  EXPECT_EQ(r.status, ExploreStatus::kLimit);
  EXPECT_EQ(r.markings, 100u);
}

TEST(Reachability, dead_transitions_are_those_never_enabled) {
  Net n;
  const PlaceId a = n.add_place("a", 1).value(), b = n.add_place("b").value(),
                never = n.add_place("never").value();
  const TransitionId ab = n.add_transition("ab").value();
  n.add_input(a, ab);
  n.add_output(ab, b);
  const TransitionId stuck = n.add_transition("stuck").value();
  n.add_input(never, stuck);
  n.add_output(stuck, a);
  const ReachabilityResult r = explore_with_bounds(n);
  EXPECT_TRUE(r.fired[ab]);
  EXPECT_FALSE(r.fired[stuck]);
}

TEST(Reachability, keeps_the_graph_when_small) {
  ExploreOptions opt;
  opt.graph_limit = 10;
  const Net net = testing::deadlock_net();
  const ReachabilityResult r = explore_with_bounds(net, opt);
  ASSERT_TRUE(r.graph.has_value());
  EXPECT_EQ(r.graph->markings.size(), 6u);
  EXPECT_EQ(r.graph->edges.size(), 8u);
  for (const auto& e : r.graph->edges) {
    EXPECT_EQ(net.fire(r.graph->markings[e.from], e.transition), r.graph->markings[e.to]);
  }
  opt.graph_limit = 3;
  EXPECT_FALSE(explore_with_bounds(net, opt).graph.has_value());
}

TEST(Reachability, packed_search_agrees_with_the_reference) {
  for (const Net& net : {philosophers(4), kanban(2), testing::deadlock_net()}) {
    const ReachabilityResult r = explore_with_bounds(net);
    const ReferenceResult ref = reference_bfs(net);
    EXPECT_EQ(r.markings, ref.markings) << net.name();
    EXPECT_EQ(r.edges, ref.edges) << net.name();
    EXPECT_EQ(r.dead_markings, ref.dead_markings) << net.name();
  }
}

TEST(Reachability, markings_spanning_several_words_work) {
  // 30 places of 5 tokens each need 90 bits: two words.
  Net n;
  std::vector<PlaceId> ps;
  for (int i = 0; i < 30; ++i)
    ps.push_back(n.add_place("p" + std::to_string(i), i == 0 ? 5 : 0).value());
  for (int i = 0; i < 30; ++i) {
    const TransitionId t = n.add_transition("t" + std::to_string(i)).value();
    n.add_input(ps[static_cast<size_t>(i)], t);
    n.add_output(t, ps[static_cast<size_t>((i + 1) % 30)]);
  }
  const ReachabilityResult r = explore_with_bounds(n);
  EXPECT_EQ(r.key_words, 2u);
  // 5 tokens over 30 places: C(34, 5) markings.
  EXPECT_EQ(r.markings, 278256u);
  EXPECT_EQ(r.markings, reference_bfs(n).markings);
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
