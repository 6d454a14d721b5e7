// SFC -> hierarchical Petri net (spec petri-sfc.md): the measuring tank's
// sub-PN of step S1 with the paper's exact numbers (eq. 10-17), the composition
// of the module matrices, and the analysis of the tank and of a broken copy.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "lang/petri/pnml.h"
#include "lang/petri/report.h"
#include "lang/sfc/net_builder.h"

namespace rtplc {
namespace {

using lang::sfc::SfcNet;
using petri::IntMatrix;
using petri::Marking;

std::string read(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

SfcNet tank(const char* file = "tank.sfc") {
  DiagnosticList d;
  const std::string src = read(std::string(RTPLC_SOURCE_DIR "/examples/") + file);
  std::optional<SfcNet> n = lang::sfc::sfc_source_to_net(src, d);
  EXPECT_TRUE(n.has_value()) << d.render(file, src);
  EXPECT_EQ(d.error_count(), 0u) << d.render(file, src);
  return n ? std::move(*n) : SfcNet{};
}

const lang::sfc::SubNet& sub(const SfcNet& n, const std::string& step) {
  for (const auto& s : n.subnets) {
    if (s.step == step) return s;
  }
  ADD_FAILURE() << "no sub-PN for " << step;
  return n.subnets.front();
}

TEST(SfcNet, the_sub_pn_of_step_s1_is_the_papers_eq_10_11_14) {
  const SfcNet n = tank();
  const auto& s1 = sub(n, "S1");
  EXPECT_EQ(s1.places, (std::vector<std::string>{"L1", "L0", "V11", "V10", "Z12", "Z11", "Z10",
                                                 "D21", "D20"}));
  EXPECT_EQ(s1.transitions, (std::vector<std::string>{"tL0", "tL1", "tv10", "tv11", "tz10", "tz11",
                                                      "tz12", "tz13", "tD20", "tD21"}));
  const IntMatrix b_s1 = IntMatrix::from_rows({
      {1, -1, 0, 0, 0, 0, 0, 0, 0, 0},
      {-1, 1, 0, 0, 0, 0, 0, 0, 0, 0},
      {0, 0, 1, -1, 0, 0, 0, 0, 0, 0},
      {0, 0, -1, 1, 0, 0, 0, 0, 0, 0},
      {0, 0, 0, 0, 1, 0, -1, 0, 0, 0},
      {0, 0, 0, 0, -1, 1, 1, -1, 0, 0},
      {0, 0, 0, 0, 0, -1, 0, 1, 0, 0},
      {0, 0, 0, 0, 0, 0, 0, 0, 1, -1},
      {0, 0, 0, 0, 0, 0, 0, 0, -1, 1},
  });
  EXPECT_EQ(s1.b, b_s1) << s1.b.to_string(s1.places, s1.transitions);
}

TEST(SfcNet, the_state_equation_on_s1_gives_the_papers_markings_eq_12_to_17) {
  const SfcNet n = tank();
  const auto& s1 = sub(n, "S1");
  const petri::Net net = s1.as_net();
  Marking x = s1.initial;
  EXPECT_EQ(x, (Marking{1, 0, 0, 1, 0, 0, 1, 1, 0}));  // eq. 12
  auto step = [&](std::vector<int> f) {
    auto r = petri::state_equation_step(net, x, f);
    EXPECT_TRUE(r) << (r ? "" : r.error());
    if (r) x = *r;
  };
  step({0, 1, 1, 0, 0, 0, 0, 0, 0, 0});                // eq. 13: tL1 and tv10
  EXPECT_EQ(x, (Marking{0, 1, 1, 0, 0, 0, 1, 1, 0}));  // eq. 15: lamp off, valve 1 open
  step({0, 0, 0, 0, 0, 1, 0, 0, 0, 0});                // tz11
  EXPECT_EQ(x, (Marking{0, 1, 1, 0, 0, 1, 0, 1, 0}));  // eq. 16: level N
  step({0, 0, 0, 0, 1, 0, 0, 0, 0, 1});                // tz10 and tD21
  EXPECT_EQ(x, (Marking{0, 1, 1, 0, 1, 0, 0, 0, 1}));  // eq. 17: level H, LS2 off = Su1 marked
}

TEST(SfcNet, the_same_firings_in_the_whole_net_move_the_main_loop_from_s1_to_s2) {
  const SfcNet n = tank();
  const petri::Net& net = n.flat();
  auto t = [&](const char* id) { return *net.find_transition(id); };
  auto p = [&](const char* id) { return *net.find_place(id); };
  // The operator presses PBS, t0 starts the charge; then the S1 firings of eq. 13-17
  // (tD21 before tz10: in the whole net the level reaches H only after LS2 let go).
  auto m = petri::fire_sequence(
      net, net.initial_marking(),
      {t("tp10"), t("t0"), t("tL1"), t("tv10"), t("tz11"), t("tD21"), t("tz10")});
  ASSERT_TRUE(m) << m.error();
  EXPECT_EQ((*m)[p("S1")], 1u);
  EXPECT_TRUE(net.enabled(*m, t("t1"))) << "D20 (Su1) marked: the main loop may leave S1";
  auto m2 = petri::fire_sequence(net, *m, {t("t1")});
  ASSERT_TRUE(m2);
  EXPECT_EQ((*m2)[p("S2")], 1u);
  EXPECT_EQ((*m2)[p("S1")], 0u);
}

TEST(SfcNet, the_whole_net_is_the_papers_22_by_23_and_composes_from_its_modules) {
  const SfcNet n = tank();
  const petri::Net& net = n.flat();
  EXPECT_EQ(net.place_count(), 22u);
  EXPECT_EQ(net.transition_count(), 23u);
  EXPECT_EQ(n.modules.front().places,
            (std::vector<std::string>{"S0", "S1", "S2", "S3", "S4", "S5", "S6", "P1", "P0"}));
  EXPECT_EQ(n.modules.front().transitions,
            (std::vector<std::string>{"t0", "t1", "t2", "t3", "t4", "t5", "t6", "tp10", "tp11"}));
  auto composed = petri::compose(n.modules, petri::place_ids(net), petri::transition_ids(net));
  ASSERT_TRUE(composed) << composed.error();
  EXPECT_EQ(*composed, net.incidence());
  size_t largest = 0;
  for (const auto& s : n.subnets) largest = std::max(largest, s.places.size());
  EXPECT_LE(largest, 13u) << "the paper's largest sub-matrix is 13 x 13";
}

TEST(SfcNet, the_tank_has_no_deadlock_and_reaches_every_step) {
  const SfcNet n = tank();
  const petri::Net& net = n.flat();
  const petri::Analysis a = petri::analyze(net);
  ASSERT_TRUE(a.reach.exact());
  EXPECT_EQ(a.reach.dead_markings, 0u);
  EXPECT_TRUE(a.reach.safe());
  for (int i = 0; i < 7; ++i) {
    const std::string s = "S" + std::to_string(i);
    EXPECT_EQ(a.reach.max_tokens[*net.find_place(s)], 1u) << s;
  }
  for (petri::TransitionId t = 0; t < net.transition_count(); ++t) {
    EXPECT_TRUE(a.reach.fired[t]) << net.transition(t).id << " never fires";
  }
}

TEST(SfcNet, the_broken_tank_deadlocks_and_the_report_gives_the_firing_sequence) {
  const SfcNet n = tank("tank_broken.sfc");
  const petri::Net& net = n.flat();
  const petri::Analysis a = petri::analyze(net);
  ASSERT_TRUE(a.reach.exact());
  ASSERT_GT(a.reach.dead_markings, 0u);
  // Two ways to hang: stuck in S5 with the tank empty (LS1 never comes back),
  // and — when LS1 is still on as S5 starts — a premature t5 that closes valve 2
  // with the tank full, so S0 waits for LS2 forever.
  const petri::DeadMarking* empty = nullptr;
  for (const petri::DeadMarking& d : a.reach.dead_examples) {
    if (d.marking[*net.find_place("S5")] == 1 && d.marking[*net.find_place("Z10")] == 1) {
      empty = &d;
      break;
    }
  }
  ASSERT_NE(empty, nullptr) << "stuck draining with the tank empty";
  const std::string seq = petri::sequence_text(net, empty->path);
  EXPECT_NE(seq.find("t4"), std::string::npos) << seq;
  const std::string text = lang::sfc::render_hierarchy(n) + petri::render_text(net, a);
  EXPECT_NE(text.find(seq), std::string::npos) << text;
}

TEST(SfcNet, the_shipped_pnml_is_the_tank_charts_net) {
  const SfcNet n = tank();
  petri::PnmlReadResult r = petri::read_pnml(read(RTPLC_SOURCE_DIR "/examples/petri/tank.pnml"));
  ASSERT_TRUE(r.net)
      << "regenerate: rtplc analyze examples/tank.sfc --write-pnml examples/petri/tank.pnml";
  EXPECT_EQ(petri::place_ids(*r.net), petri::place_ids(n.flat()));
  EXPECT_EQ(petri::transition_ids(*r.net), petri::transition_ids(n.flat()));
  EXPECT_EQ(r.net->input_matrix(), n.flat().input_matrix()) << "read arcs included";
  EXPECT_EQ(r.net->output_matrix(), n.flat().output_matrix());
  EXPECT_EQ(r.net->initial_marking(), n.flat().initial_marking());
}

TEST(SfcNet, or_conditions_become_one_transition_per_alternative) {
  DiagnosticList d;
  auto n = lang::sfc::sfc_source_to_net(
      "SFC x\nINPUT A = ddi(p0, d0, c0) MODEL a1 a0\nINPUT B = ddi(p0, d0, c1) MODEL b1 b0\n"
      "INITIAL STEP S\nEND_STEP\nSTEP U\nEND_STEP\n"
      "TRANSITION go FROM S TO U WHEN A OR NOT B\nTRANSITION back FROM U TO S WHEN NOT (A OR B)\n"
      "PLANT\nMODULE ma: a1 a0*\nMODULE mb: b1 b0*\nEND_PLANT\n",
      d);
  ASSERT_TRUE(n) << d.render("x", "");
  const petri::Net& net = n->flat();
  ASSERT_TRUE(net.find_transition("go") && net.find_transition("go.2"));
  EXPECT_FALSE(net.find_transition("back.2")) << "NOT (A OR B) is one conjunction";
  const petri::TransitionId back = *net.find_transition("back");
  EXPECT_EQ(net.pre(*net.find_place("a0"), back), 1u);
  EXPECT_EQ(net.pre(*net.find_place("b0"), back), 1u);
  EXPECT_EQ(net.incidence()(*net.find_place("a0"), back), 0) << "a read arc";
}

}  // namespace
}  // namespace rtplc
