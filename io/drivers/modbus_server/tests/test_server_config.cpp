// The modbus-server's config: defaults, and every bad value refused with its
// line and column.
#include <gtest/gtest.h>

#include "config/config.h"
#include "io/drivers/modbus_server/config.h"

namespace rtplc::modbus_server {
namespace {

const char* kTask = "tasks:\n  - {name: t, program: p.fbd}\n";

config::LoadResult parse(const std::string& driver) {
  return config::parse_config(std::string(kTask) + "drivers:\n  - kind: modbus-server\n    name: scada\n" + driver,
                              "c.yaml", "", config::LoadOptions{false});
}

TEST(ServerConfig, defaults_serve_loopback_on_502_to_every_unit) {
  auto r = parse("    expose:\n      - {label: ProcVal, table: ir, address: 0, type: f32}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const ServerSettings& s = settings_of(r.config->drivers[0]);
  EXPECT_EQ(s.bind, "127.0.0.1");
  EXPECT_EQ(s.port, 502);
  EXPECT_EQ(s.max_clients, 16u);
  EXPECT_TRUE(s.answers(0));
  EXPECT_TRUE(s.answers(255));
  ASSERT_EQ(s.allow.size(), 1u);
  EXPECT_TRUE(s.allows(0x7F000001));   // 127.0.0.1
  EXPECT_TRUE(s.allows(0x7F0000FE));   // 127.0.0.254
  EXPECT_FALSE(s.allows(0x0A000007));  // 10.0.0.7
  ASSERT_EQ(s.items.size(), 1u);
  EXPECT_EQ(s.items[0].item.table, modbus::Table::kInputRegister);
  EXPECT_EQ(s.items[0].item.type, modbus::ItemType::kF32);
  EXPECT_FALSE(s.items[0].item.swapped);
}

TEST(ServerConfig, reads_units_allow_and_item_options) {
  auto r = parse(
      "    bind: 0.0.0.0\n    port: 1502\n    units: [1, 7]\n    max_clients: 4\n    timeout: 5s\n"
      "    allow: [10.0.0.0/24, 192.168.1.7]\n    expose:\n"
      "      - {label: Setpoint, table: hr, address: 10, type: i16, scale: 0.1, offset: 5}\n"
      "      - {label: Setpoint, table: hr, address: 11, type: f32, word_order: low_first}\n"
      "      - {label: Run, table: coil, address: 0}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const ServerSettings& s = settings_of(r.config->drivers[0]);
  EXPECT_EQ(s.port, 1502);
  EXPECT_TRUE(s.answers(7));
  EXPECT_FALSE(s.answers(2));
  EXPECT_TRUE(s.allows(0x0A0000FF));
  EXPECT_FALSE(s.allows(0x0A000100));
  EXPECT_TRUE(s.allows(0xC0A80107));
  EXPECT_FALSE(s.allows(0x7F000001));  // an explicit list replaces loopback
  EXPECT_EQ(s.timeout_s, 5);
  EXPECT_EQ(s.items[0].scale, 0.1);
  EXPECT_EQ(s.items[0].offset, 5);
  EXPECT_TRUE(s.items[1].item.swapped);
  EXPECT_EQ(s.items[2].item.type, modbus::ItemType::kBit);
}

// Each bad value is reported at its own line:column.
TEST(ServerConfig, bad_values_are_refused_with_their_position) {
  auto r = parse(
      "    bind: localhost\n"                                                  // line 6
      "    units: [1, 300]\n"                                                  // 7
      "    allow: [10.0.0.0/33]\n"                                             // 8
      "    expose:\n"                                                          // 9
      "      - {label: A, table: coil, address: 0, type: f32}\n"               // 10
      "      - {label: B, table: hr, address: 65535, type: f32}\n"             // 11
      "      - {label: C, table: hr, address: 0, type: u16, word_order: low_first}\n"  // 12
      "      - {label: D, table: hr, address: 0, scale: 0}\n"                  // 13
      "      - {label: E, table: xx, address: 0}\n"                            // 14
      "      - {label: F, table: ir, address: 4, type: f32}\n"                 // 15
      "      - {label: G, table: ir, address: 5}\n");                          // 16
  EXPECT_FALSE(r.ok());
  const std::string out = r.render();
  EXPECT_NE(out.find("c.yaml:6:11: error: 'bind' must be a numeric IPv4"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:7:16: error: a unit id is a whole number 0..255"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:8:13: error: 'allow' takes numeric IPv4"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:10:"), std::string::npos) << out;
  EXPECT_NE(out.find("'type' applies to registers (ir, hr) only"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:11:"), std::string::npos) << out;
  EXPECT_NE(out.find("address + 1 <= 65535"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:12:"), std::string::npos) << out;
  EXPECT_NE(out.find("'word_order' applies to two-register types"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:13:"), std::string::npos) << out;
  EXPECT_NE(out.find("'scale' must not be 0"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:14:"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:16:9: error: ir 5 is already F's (line 15)"), std::string::npos) << out;
}

TEST(ServerConfig, expose_is_required_and_unknown_keys_are_named) {
  auto r = parse("    port: 1502\n    exposed: []\n");
  EXPECT_FALSE(r.ok());
  const std::string out = r.render();
  EXPECT_NE(out.find("c.yaml:4:5: error: a modbus-server driver needs 'expose'"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:7:5: error: unknown key 'exposed' in a modbus-server driver; did you mean 'expose'?"),
            std::string::npos)
      << out;
}

TEST(ServerConfig, binding_beyond_loopback_without_allow_warns_that_only_loopback_is_served) {
  auto r = parse("    bind: 0.0.0.0\n    expose: [{label: A, table: ir, address: 0}]\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_NE(r.render().find("warning: without 'allow' only loopback clients are served"), std::string::npos)
      << r.render();
}

TEST(ServerConfig, parse_allow_takes_addresses_and_networks) {
  AllowRule a;
  ASSERT_TRUE(parse_allow("10.1.2.3/16", a));
  EXPECT_TRUE(a.matches(0x0A01FFFF));
  EXPECT_FALSE(a.matches(0x0A020000));
  ASSERT_TRUE(parse_allow("0.0.0.0/0", a));
  EXPECT_TRUE(a.matches(0xDEADBEEF));
  EXPECT_FALSE(parse_allow("10.0.0.1/", a));
  EXPECT_FALSE(parse_allow("host", a));
  EXPECT_FALSE(parse_allow("10.0.0.1/x", a));
}

}  // namespace
}  // namespace rtplc::modbus_server
