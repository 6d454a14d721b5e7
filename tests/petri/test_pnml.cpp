// PNML import and export (issue item 3, "PNML"): round trip, the 2009 grammar's
// corners, refusals by name and errors with line:col.
#include <gtest/gtest.h>

#include "lang/petri/generators.h"
#include "lang/petri/pnml.h"
#include "tests/petri/test_support.h"

namespace rtplc::petri {
namespace {

std::string doc(const std::string& body, const std::string& type = std::string(kPtNetType)) {
  return "<?xml version=\"1.0\"?>\n<pnml xmlns=\"http://www.pnml.org/version-2009/grammar/pnml\">\n"
         "<net id=\"n\" type=\"" +
         type + "\">\n" + body + "\n</net>\n</pnml>\n";
}

void expect_same_net(const Net& a, const Net& b) {
  ASSERT_EQ(a.place_count(), b.place_count());
  ASSERT_EQ(a.transition_count(), b.transition_count());
  for (PlaceId p = 0; p < a.place_count(); ++p) {
    EXPECT_EQ(a.place(p).id, b.place(p).id);
    EXPECT_EQ(a.place(p).initial, b.place(p).initial);
    EXPECT_EQ(a.place_label(p), b.place_label(p));
  }
  for (TransitionId t = 0; t < a.transition_count(); ++t)
    EXPECT_EQ(a.transition(t).id, b.transition(t).id);
  EXPECT_EQ(a.input_matrix(), b.input_matrix());
  EXPECT_EQ(a.output_matrix(), b.output_matrix());
}

std::string first_error(const PnmlReadResult& r) {
  return r.diags.items().empty() ? "" : r.diags.items().front().message;
}

TEST(Pnml, write_then_read_gives_the_same_net) {
  for (const Net& net :
       {testing::deadlock_net(), testing::producer_net(), kanban(2), philosophers(3)}) {
    const PnmlReadResult r = read_pnml(write_pnml(net));
    ASSERT_TRUE(r.net.has_value()) << net.name() << ": " << first_error(r);
    EXPECT_EQ(r.net->name(), net.name());
    expect_same_net(*r.net, net);
  }
}

TEST(Pnml, weights_and_odd_names_survive_the_round_trip) {
  Net n("a <net> & \"quotes\"");
  const PlaceId p = n.add_place("p&1", 7, "place <one>").value();
  const TransitionId t = n.add_transition("t'1").value();
  n.add_input(p, t, 3);
  n.add_output(t, p, 5);
  const PnmlReadResult r = read_pnml(write_pnml(n));
  ASSERT_TRUE(r.net.has_value()) << first_error(r);
  EXPECT_EQ(r.net->name(), n.name());
  expect_same_net(*r.net, n);
}

TEST(Pnml, nested_pages_forward_references_and_defaults) {
  const PnmlReadResult r = read_pnml(doc(R"(
    <page id="top">
      <arc id="a1" source="p" target="t"/>
      <page id="inner"><page id="innermost">
        <transition id="t"><graphics><position x="1" y="2"/></graphics></transition>
      </page></page>
      <arc id="a2" source="t" target="q"><inscription><text> 4 </text></inscription>
        <graphics><position x="5" y="5"/></graphics></arc>
      <place id="p"><initialMarking><text>2</text></initialMarking>
        <toolspecific tool="x" version="1"><anything><deeper/></anything></toolspecific></place>
      <place id="q"/>
    </page>)"));
  ASSERT_TRUE(r.net.has_value()) << first_error(r);
  const Net& n = *r.net;
  const PlaceId p = *n.find_place("p"), q = *n.find_place("q");
  const TransitionId t = *n.find_transition("t");
  EXPECT_EQ(n.place(p).initial, 2u);
  EXPECT_EQ(n.place(q).initial, 0u);  // no initialMarking: no tokens
  EXPECT_EQ(n.pre(p, t), 1u);         // no inscription: weight 1
  EXPECT_EQ(n.post(q, t), 4u);
}

TEST(Pnml, reference_nodes_stand_for_the_node_they_name) {
  const PnmlReadResult r = read_pnml(doc(R"(
    <page id="a"><place id="p"><initialMarking><text>1</text></initialMarking></place>
      <transition id="t"/></page>
    <page id="b"><referencePlace id="rp2" ref="rp"/><referencePlace id="rp" ref="p"/>
      <referenceTransition id="rt" ref="t"/>
      <arc id="x" source="rp2" target="rt"/></page>)"));
  ASSERT_TRUE(r.net.has_value()) << first_error(r);
  EXPECT_EQ(r.net->place_count(), 1u);
  EXPECT_EQ(r.net->pre(0, 0), 1u);
}

TEST(Pnml, coloured_net_is_refused_by_name) {
  const PnmlReadResult r =
      read_pnml(doc("<page id=\"p\"/>", "http://www.pnml.org/version-2009/grammar/symmetricnet"));
  EXPECT_FALSE(r.net.has_value());
  EXPECT_NE(first_error(r).find("symmetric net (coloured)"), std::string::npos) << first_error(r);
  EXPECT_EQ(r.diags.items().front().pos.line, 3u);
}

TEST(Pnml, malformed_xml_is_reported_with_its_position) {
  const PnmlReadResult r =
      read_pnml("<pnml>\n  <net id=\"n\" type=\"x\">\n    <page id=\"p\">\n  </net>\n</pnml>\n");
  ASSERT_FALSE(r.net.has_value());
  ASSERT_FALSE(r.diags.items().empty());
  EXPECT_EQ(first_error(r), "</net> closes <page>");
  EXPECT_EQ(r.diags.items().front().pos.line, 4u);
  EXPECT_EQ(r.diags.items().front().pos.col, 3u);
}

TEST(Pnml, unknown_arc_end_is_an_error_at_the_attribute) {
  const PnmlReadResult r = read_pnml(doc(
      "<page id=\"p\"><place id=\"a\"/>\n<arc id=\"x\" source=\"a\" target=\"nowhere\"/></page>"));
  ASSERT_FALSE(r.net.has_value());
  EXPECT_NE(first_error(r).find("'nowhere'"), std::string::npos);
  EXPECT_EQ(r.diags.items().front().pos.line, 5u);
  EXPECT_EQ(r.diags.items().front().pos.col, 24u);
}

TEST(Pnml, bad_contents_are_errors_not_crashes) {
  const char* cases[] = {
      "",
      "<",
      "<pnml",
      "<pnml></pnml>",
      "<pnml><net id=\"n\"/></pnml>",
      "<pnml><net id=\"n\" type=\"x\" type=\"y\"/></pnml>",
      "<pnml>&bogus;</pnml>",
      "<pnml>&#0;</pnml>",
      "<pnml><!-- never closed </pnml>",
      "<pnml><![CDATA[ open </pnml>",
      "<a></a><b/>",
  };
  for (const char* c : cases) {
    const PnmlReadResult r = read_pnml(c);
    EXPECT_FALSE(r.net.has_value()) << c;
    EXPECT_TRUE(r.diags.has_errors()) << c;
  }
  EXPECT_FALSE(
      read_pnml(doc("<page id=\"p\"><place "
                    "id=\"a\"><initialMarking><text>-1</text></initialMarking></place></page>"))
          .net);
  EXPECT_FALSE(read_pnml(doc("<page id=\"p\"><place id=\"a\"/><place id=\"a\"/></page>")).net);
  EXPECT_FALSE(read_pnml(doc("<page id=\"p\"><place id=\"a\"/><place id=\"b\"/><arc id=\"x\" "
                             "source=\"a\" target=\"b\"/></page>"))
                   .net);
  EXPECT_FALSE(
      read_pnml(
          doc("<page id=\"p\"><place id=\"a\"/><transition id=\"t\"/><arc id=\"x\" source=\"a\" "
              "target=\"t\"><inscription><text>0</text></inscription></arc></page>"))
          .net);
  std::string deep;
  for (int i = 0; i < 1000; ++i) deep += "<page id=\"p" + std::to_string(i) + "\">";
  const PnmlReadResult r = read_pnml(doc(deep));
  EXPECT_FALSE(r.net.has_value());
  EXPECT_NE(first_error(r).find("nested deeper"), std::string::npos);
}

TEST(Pnml, character_references_and_cdata_are_decoded) {
  const PnmlReadResult r =
      read_pnml(doc("<name><text>caf&#xE9; &amp; <![CDATA[<tea>]]></text></name><page "
                    "id=\"p\"><place id=\"a\"/></page>"));
  ASSERT_TRUE(r.net.has_value()) << first_error(r);
  EXPECT_EQ(r.net->name(), "caf\xC3\xA9 & <tea>");
}

}  // namespace
}  // namespace rtplc::petri
