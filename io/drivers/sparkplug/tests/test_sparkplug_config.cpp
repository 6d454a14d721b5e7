// The sparkplug driver's config: defaults, the broker's spellings, and every
// bad value refused with its line and column.
#include <gtest/gtest.h>

#include "config/config.h"
#include "io/drivers/sparkplug/config.h"

namespace rtplc::sparkplug {
namespace {

const char* kTask = "tasks:\n  - {name: t, program: p.fbd}\n";

config::LoadResult parse(const std::string& driver) {
  return config::parse_config(std::string(kTask) + "drivers:\n  - kind: sparkplug\n    name: plant\n" + driver,
                              "c.yaml", "", config::LoadOptions{false});
}

TEST(SparkplugConfig, defaults_publish_everything_over_mqtt5_with_a_store) {
  auto r = parse("    broker: 127.0.0.1:1883\n    group: Plant1\n    node: rtplc-01\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const SparkplugSettings& s = settings_of(r.config->drivers[0]);
  EXPECT_EQ(s.host, "127.0.0.1");
  EXPECT_EQ(s.port, 1883);
  EXPECT_FALSE(s.tls);
  EXPECT_TRUE(s.mqtt5);
  EXPECT_TRUE(s.publish_all);
  EXPECT_TRUE(s.writable.empty());
  EXPECT_EQ(s.store_and_forward, 10000u);
  EXPECT_EQ(s.primary_host, "");
  EXPECT_EQ(s.keepalive_s, 10);
  EXPECT_EQ(s.broker_text(), "127.0.0.1:1883");
}

TEST(SparkplugConfig, reads_tls_brokers_lists_and_deadbands) {
  auto r = parse(
      "    broker: mqtts://broker.plant\n    ca: ca.pem\n    username: box1\n    password: secret\n"
      "    group: Plant1\n    node: rtplc-01\n    primary_host: scada\n    publish: [ProcVal, Setpoint]\n"
      "    deadband: {ProcVal: 0.5}\n    writable: [Setpoint]\n    aliases: true\n    mqtt: 3.1.1\n"
      "    store_and_forward: 0\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const SparkplugSettings& s = settings_of(r.config->drivers[0]);
  EXPECT_TRUE(s.tls);
  EXPECT_EQ(s.port, 8883);
  EXPECT_EQ(s.host, "broker.plant");
  EXPECT_NE(s.ca_file.find("ca.pem"), std::string::npos);
  EXPECT_EQ(s.username, "box1");
  EXPECT_FALSE(s.publish_all);
  EXPECT_EQ(s.publish, (std::vector<std::string>{"ProcVal", "Setpoint"}));
  EXPECT_EQ(s.deadband.at("ProcVal"), 0.5);
  EXPECT_TRUE(s.aliases);
  EXPECT_FALSE(s.mqtt5);
  EXPECT_EQ(s.store_and_forward, 0u);
  EXPECT_EQ(s.broker_text(), "mqtts://broker.plant:8883");
}

TEST(SparkplugConfig, publish_all_is_a_word_too) {
  auto r = parse("    broker: mqtt://b:1884\n    group: G\n    node: N\n    publish: all\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_TRUE(settings_of(r.config->drivers[0]).publish_all);
  EXPECT_EQ(settings_of(r.config->drivers[0]).port, 1884);
}

TEST(SparkplugConfig, bad_values_are_refused_with_their_position) {
  auto r = parse(
      "    broker: tcp://x:1\n"          // line 6
      "    group: Plant/1\n"             // 7
      "    node: rtplc#1\n"              // 10
      "    ca: ca.pem\n"                 // 9: no TLS
      "    deadband: {ProcVal: -1}\n"    // 8
      "    writable: [Setpoint, Setpoint]\n"  // 11
      "    password: x\n");              // 12: no user name
  EXPECT_FALSE(r.ok());
  const std::string out = r.render();
  EXPECT_NE(out.find("c.yaml:6:13: error: 'broker' the broker's scheme is mqtt:// or mqtts://"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:7:12: error: 'group' is a Sparkplug id"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:8:11: error: 'node' is a Sparkplug id"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:9:9: error: 'ca' applies to a TLS broker"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:10:16:"), std::string::npos) << out;
  EXPECT_NE(out.find("the deadband of \"ProcVal\" is a change >= 0"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:11:26: error: \"Setpoint\" is listed twice"), std::string::npos) << out;
  EXPECT_NE(out.find("c.yaml:12:15: error: 'password' needs a 'username'"), std::string::npos) << out;
}

TEST(SparkplugConfig, the_identity_is_required) {
  auto r = parse("    broker: 127.0.0.1\n");
  EXPECT_FALSE(r.ok());
  const std::string out = r.render();
  EXPECT_NE(out.find("needs 'group'"), std::string::npos) << out;
  EXPECT_NE(out.find("needs 'node'"), std::string::npos) << out;
}

TEST(SparkplugConfig, ids_reject_mqtt_specials) {
  EXPECT_TRUE(valid_id("rtplc-01"));
  EXPECT_TRUE(valid_id("Plant 1"));
  EXPECT_FALSE(valid_id(""));
  EXPECT_FALSE(valid_id("a/b"));
  EXPECT_FALSE(valid_id("a+"));
  EXPECT_FALSE(valid_id("#"));
  EXPECT_FALSE(valid_id(std::string(65, 'x')));
}

}  // namespace
}  // namespace rtplc::sparkplug
