// The plan file loader: the forms it accepts and the positioned errors it gives.
#include <gtest/gtest.h>

#include "fieldbus/plan_file.h"

namespace rtplc::fieldbus {
namespace {

constexpr Nanos us = 1'000;

// The rendered diagnostics of a file that must not load.
std::string errors_of(const std::string& yaml) {
  PlanFile pf = parse_plan_file(yaml, "plan.yaml");
  EXPECT_FALSE(pf.design.has_value()) << yaml;
  return pf.render();
}

const char* kGood =
    "link: {nodes: 10, server_overhead: 20us}\n"
    "periodic: {packet: 100us}\n"
    "realtime: {queues: 2, packet: 150us}\n"
    "loops:\n"
    "  - {name: L1, period: 5ms}\n"
    "  - {name: L2, max_delay: 25ms}\n";

TEST(FieldbusPlanFile, reads_the_generic_form) {
  PlanFile pf = parse_plan_file(kGood, "plan.yaml");
  ASSERT_TRUE(pf.design.has_value()) << pf.render();
  const Design& d = *pf.design;
  EXPECT_EQ(d.nodes, 10);
  EXPECT_EQ(d.server_overhead, 20 * us);
  EXPECT_EQ(d.periodic_packet, 100 * us);
  EXPECT_EQ(d.rt_queues, 2);
  EXPECT_EQ(d.rt_packet, 150 * us);
  ASSERT_EQ(d.loops.size(), 2u);
  EXPECT_EQ(d.loops[0].period, 5'000 * us);
  EXPECT_FALSE(d.loops[0].max_delay.has_value());
  EXPECT_EQ(d.loops[1].max_delay, 25'000 * us);
  EXPECT_FALSE(d.nonrt_packet.has_value());
}

TEST(FieldbusPlanFile, computes_can_packet_times_from_the_layout) {
  PlanFile pf = parse_plan_file(
      "link: {nodes: 8, bit_rate: 500kbit/s, layout: can-11, access: token}\n"
      "periodic: {bytes: 8}\n"
      "realtime: {queues: 2, bytes: 2, rate: 20}\n"
      "nonrt: {bytes: 8, rate: 100}\n"
      "loops:\n  - {name: a, period: 10ms, sensor: 3, controller: 7}\n",
      "can.yaml");
  ASSERT_TRUE(pf.design.has_value()) << pf.render();
  const Design& d = *pf.design;
  EXPECT_EQ(d.periodic_packet, 270 * us);  // 135 bits
  EXPECT_EQ(d.rt_packet, 150 * us);        // 75 bits
  EXPECT_EQ(d.server_overhead, 110 * us);  // a token frame with no data: 55 bits
  EXPECT_EQ(d.nonrt_packet, 270 * us);
  EXPECT_EQ(d.access, Access::kTokenPassing);
  EXPECT_EQ(d.rt_rate, 20);
  EXPECT_EQ(d.nonrt_rate, 100);
  EXPECT_EQ(d.loops[0].sensor_node, 3);
  EXPECT_EQ(d.loops[0].controller_node, 7);
  EXPECT_EQ(d.link_text, "CAN 11-bit id at 500kbit/s");
}

TEST(FieldbusPlanFile, unknown_key_gets_position_caret_and_hint) {
  const std::string e = errors_of(
      "link: {nodes: 10, server_overhed: 20us}\nperiodic: {packet: 100us}\n"
      "loops:\n  - {name: L1, period: 5ms}\n");
  EXPECT_NE(e.find("plan.yaml:1:19: error: unknown key 'server_overhed' in the link; did you "
                   "mean 'server_overhead'?"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("^~~~~~~~~~~~~"), std::string::npos) << e;
}

TEST(FieldbusPlanFile, malformed_time_points_at_the_value) {
  const std::string e = errors_of(
      "link: {nodes: 10, server_overhead: 20us}\nperiodic: {packet: fast}\n"
      "loops:\n  - {name: L1, period: 5ms}\n");
  EXPECT_NE(e.find("plan.yaml:2:20: error: 'packet' expects a time such as 100us"),
            std::string::npos)
      << e;
}

TEST(FieldbusPlanFile, zero_nodes_is_explained) {
  const std::string e = errors_of(
      "link: {nodes: 0, server_overhead: 20us}\nperiodic: {packet: 100us}\n"
      "loops:\n  - {name: L1, period: 5ms}\n");
  EXPECT_NE(e.find("plan.yaml:1:15: error: 'nodes' is 0: the server has nobody to visit"),
            std::string::npos)
      << e;
}

TEST(FieldbusPlanFile, a_loop_gives_period_or_max_delay) {
  std::string e = errors_of(
      "link: {nodes: 10, server_overhead: 20us}\nperiodic: {packet: 100us}\n"
      "loops:\n  - {name: L1, period: 5ms, max_delay: 20ms}\n  - {name: L2}\n");
  EXPECT_NE(e.find("plan.yaml:4:29: error: a loop gives 'period' or 'max_delay', not both"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("plan.yaml:5:5: error: a loop needs 'period'"), std::string::npos) << e;
}

TEST(FieldbusPlanFile, duplicate_loop_names_point_at_both) {
  const std::string e = errors_of(
      "link: {nodes: 10, server_overhead: 20us}\nperiodic: {packet: 100us}\n"
      "loops:\n  - {name: L1, period: 5ms}\n  - {name: L1, period: 10ms}\n");
  EXPECT_NE(e.find("plan.yaml:5:12: error: a second loop named 'L1'"), std::string::npos) << e;
  EXPECT_NE(e.find("plan.yaml:4:5: note: the first one is here"), std::string::npos) << e;
}

TEST(FieldbusPlanFile, bytes_need_a_layout_and_fit_a_can_frame) {
  std::string e = errors_of(
      "link: {nodes: 10, server_overhead: 20us}\nperiodic: {bytes: 8}\n"
      "loops:\n  - {name: L1, period: 5ms}\n");
  EXPECT_NE(e.find("plan.yaml:2:19: error: 'bytes' needs the link's 'bit_rate' and 'layout'"),
            std::string::npos)
      << e;
  e = errors_of(
      "link: {nodes: 10, bit_rate: 250kbit/s, layout: can-29}\nperiodic: {bytes: 12}\n"
      "loops:\n  - {name: L1, period: 5ms}\n");
  EXPECT_NE(e.find("plan.yaml:2:19: error: a can-29 packet carries at most 8 data bytes, got 12"),
            std::string::npos)
      << e;
}

TEST(FieldbusPlanFile, a_node_outside_the_link_is_refused) {
  const std::string e = errors_of(
      "link: {nodes: 4, server_overhead: 20us}\nperiodic: {packet: 100us}\n"
      "loops:\n  - {name: L1, period: 5ms, sensor: 4}\n");
  EXPECT_NE(e.find("plan.yaml:4:37: error: 'sensor' is node 4 but the link's nodes are 0 to 3"),
            std::string::npos)
      << e;
}

TEST(FieldbusPlanFile, yaml_syntax_errors_have_a_position) {
  const std::string e = errors_of("link: {nodes: 10\nperiodic: [\n");
  EXPECT_NE(e.find("plan.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("YAML syntax error"), std::string::npos) << e;
}

TEST(FieldbusPlanFile, missing_sections_are_named) {
  const std::string e = errors_of("link: {nodes: 10, server_overhead: 20us}\n");
  EXPECT_NE(e.find("plan.yaml:1:1: error: the plan file needs 'periodic'"), std::string::npos) << e;
  EXPECT_NE(e.find("needs 'loops'"), std::string::npos) << e;
}

TEST(FieldbusPlanFile, a_missing_file_is_an_error_not_a_crash) {
  PlanFile pf = load_plan_file("/nonexistent/plan.yaml");
  EXPECT_FALSE(pf.design.has_value());
  EXPECT_NE(pf.render().find("plan file not found"), std::string::npos);
}

TEST(FieldbusPlanFile, the_example_file_is_the_worked_example_the_tests_start_from) {
  PlanFile pf = load_plan_file(std::string(RTPLC_SOURCE_DIR) + "/examples/fieldbus.yaml");
  ASSERT_TRUE(pf.design.has_value()) << pf.render();
  const Design& f = *pf.design;
  const Design w = worked_example();
  EXPECT_EQ(f.nodes, w.nodes);
  EXPECT_EQ(f.server_overhead, w.server_overhead);
  EXPECT_EQ(f.periodic_packet, w.periodic_packet);
  EXPECT_EQ(f.rt_queues, w.rt_queues);
  EXPECT_EQ(f.rt_packet, w.rt_packet);
  EXPECT_EQ(f.frame, w.frame);
  EXPECT_EQ(f.nonrt_packet, w.nonrt_packet);
  ASSERT_EQ(f.loops.size(), w.loops.size());
  for (size_t i = 0; i < f.loops.size(); ++i) {
    EXPECT_EQ(f.loops[i].name, w.loops[i].name);
    EXPECT_EQ(f.loops[i].period, w.loops[i].period);
    EXPECT_EQ(f.loops[i].max_delay, w.loops[i].max_delay);
  }
}

}  // namespace
}  // namespace rtplc::fieldbus
