// Module composition B = sum_k B^_ik / D and the hierarchical net builder
// (spec petri-sfc.md, "SFC -> hierarchical PN" and "Composition").
#include <gtest/gtest.h>

#include "lang/petri/compose.h"
#include "lang/petri/generators.h"
#include "lang/petri/reachability.h"

namespace rtplc::petri {
namespace {

// A two-step main loop S0 -> S1 -> S0 with the spec's lamp and valve modules as
// the sub-PN of S1: lamp off and valve open while S1 is active (rule 3), and the
// main transition t1 waits for the valve to be open (rule 4).
HierarchicalNet small_hierarchy() {
  HierarchicalNet h("two-step");
  const PlaceId s0 = h.add_step("S0", true).value();
  const PlaceId s1 = h.add_step("S1").value();
  const TransitionId t0 = h.add_step_transition("t0").value();
  const TransitionId t1 = h.add_step_transition("t1").value();
  h.leave(s0, t0);
  h.enter(t0, s1);
  h.leave(s1, t1);
  h.enter(t1, s0);
  const size_t sub = h.add_subnet("S1-actions", s1);
  const PlaceId l1 = h.add_sub_place(sub, "L1", 1).value();
  const PlaceId l0 = h.add_sub_place(sub, "L0").value();
  const PlaceId v11 = h.add_sub_place(sub, "V11").value();
  const PlaceId v10 = h.add_sub_place(sub, "V10", 1).value();
  const TransitionId tl1 = h.add_sub_transition(sub, "tL1").value();
  const TransitionId tv10 = h.add_sub_transition(sub, "tv10").value();
  Net& n = h.net();
  n.add_input(l1, tl1);
  n.add_output(tl1, l0);
  n.add_input(v10, tv10);
  n.add_output(tv10, v11);
  h.starts_on(sub, tl1);
  h.starts_on(sub, tv10);
  h.finishes(sub, v11, t1);
  return h;
}

TEST(Compose, hierarchical_modules_compose_to_the_flat_incidence_matrix) {
  const HierarchicalNet h = small_hierarchy();
  const std::vector<Module> mods = h.modules();
  ASSERT_EQ(mods.size(), 2u);
  EXPECT_EQ(mods[0].places, (std::vector<std::string>{"S0", "S1"}));
  EXPECT_EQ(mods[1].places, (std::vector<std::string>{"L1", "L0", "V11", "V10"}));
  auto b = compose(mods, place_ids(h.flat()), transition_ids(h.flat()));
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(*b, h.flat().incidence());
}

TEST(Compose, read_arcs_keep_tokens_in_their_own_loop) {
  const HierarchicalNet h = small_hierarchy();
  const Net& n = h.flat();
  const ReachabilityResult r = explore(n);
  ASSERT_TRUE(r.exact());
  // The sub-PN moves only while S1 is marked, and t1 waits for V11.
  auto m = fire_sequence(n, n.initial_marking(), {*n.find_transition("t0")});
  ASSERT_TRUE(m.ok());
  EXPECT_FALSE(n.enabled(*m, *n.find_transition("t1")));
  EXPECT_FALSE(n.enabled(n.initial_marking(), *n.find_transition("tL1")));
  auto done = fire_sequence(n, *m, {*n.find_transition("tv10"), *n.find_transition("t1")});
  ASSERT_TRUE(done.ok()) << done.error();
  EXPECT_EQ((*done)[*n.find_place("S0")], 1u);
  EXPECT_EQ((*done)[*n.find_place("V11")], 1u);  // the valve's token stayed in its module
  // Every marking keeps one token in the main loop.
  EXPECT_EQ(r.max_tokens_in_place, 1u);
}

TEST(Compose, a_module_listed_twice_is_divided_by_its_multiplicity) {
  const HierarchicalNet h = small_hierarchy();
  std::vector<Module> mods = h.modules();
  mods.push_back(mods[1]);  // D = 2 for the sub-PN
  auto b = compose(mods, place_ids(h.flat()), transition_ids(h.flat()));
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(*b, h.flat().incidence());
}

TEST(Compose, overlapping_modules_are_refused) {
  const HierarchicalNet h = small_hierarchy();
  std::vector<Module> mods = h.modules();
  Module other = mods[1];
  other.name = "copy";
  mods.push_back(other);
  auto b = compose(mods, place_ids(h.flat()), transition_ids(h.flat()));
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("both define"), std::string::npos) << b.error();
}

TEST(Compose, kanban_split_by_its_invariants_composes_back) {
  // Cai et al.'s split: one module per station (a token loop).
  const Net net = kanban(2);
  auto mods = modules_from_invariants(net, p_invariants(net));
  ASSERT_TRUE(mods.ok()) << mods.error();
  ASSERT_EQ(mods->size(), 4u);
  for (const Module& m : *mods) EXPECT_EQ(m.places.size(), 4u);
  auto b = compose(*mods, place_ids(net), transition_ids(net));
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(*b, net.incidence());
}

TEST(Compose, a_module_naming_an_unknown_place_is_refused) {
  Module m{"m", {"nope"}, {}, IntMatrix(1, 0)};
  EXPECT_FALSE(compose({m}, {"p"}, {}).ok());
}

}  // namespace
}  // namespace rtplc::petri
