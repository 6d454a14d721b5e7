// A program sees its inputs' quality through the `good` block and switches to a
// safe branch while an input is bad: here a Modbus slave (the fake, with its
// whole-slave faults) killed and restarted under a running runtime, and a
// channel no driver feeds, which no one vouches for; a forced input counts as
// good (the operator vouches for it).
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "io/drivers/modbus/fake_slave.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/eventually.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::channel_value;
using rtplc::testing::RuntimeFixture;

using rtplc::testing::eventually;

// Level from the slave; while it is not good, the output takes the fallback.
const char* kProgram =
    "%%\nstime(0.02)\nF1 = prr(p1, d0, c0, \"Level\")\nD2 = good(F1)\n"
    "F3 = asp(d0, c0, -5, \"Fallback\")\nF4 = amux(F3, F1, D2)\n"
    "dao(F4, p0, d0, c9, \"Safe\")\nddo(D2, p0, d0, c8, \"LevelOk\")\n"
    "F5 = dai(p0, d3, c0, \"Unfed\")\nD6 = good(F5)\nddo(D6, p0, d0, c7, \"UnfedOk\")\n"
    "F7 = sub(F1, F3, 1)\ndao(F7, p0, d0, c6, \"FromLevel\")\n"
    "D8 = dsp(d0, c1, 1, \"Run\")\nD9 = and(D8, D2)\nddo(D9, p0, d0, c5, \"Enable\")\nEND\n";

Quality quality_of_label(sched::Runtime& rt, const char* label) {
  const int c = rt.image().find_channel(label);
  return c < 0 ? Quality::kBad : rt.image().read_channel(static_cast<uint32_t>(c)).quality;
}

std::string config(uint16_t port, const char* timeout = "100ms") {
  return "tasks:\n  - {name: t, program: p.fbd}\n"
         "drivers:\n  - kind: modbus\n    name: mb\n    period: 10ms\n    slaves:\n"
         "      - {name: a, address: 127.0.0.1, port: " + std::to_string(port) +
         ", poll: 20ms, timeout: " + timeout + ", retries: 0}\n"
         "    read:\n      - {device: R, channel: p1.d0.c0, slave: a, address: 0, type: f32}\n";
}

TEST(QualityInPrograms, a_program_switches_to_its_safe_branch_while_an_input_is_bad) {
  modbus::FakeSlave slave;
  ASSERT_TRUE(slave.start().ok());
  slave.put(*modbus::parse_address("hr:0:f32"), 2.5);
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  auto rt = fx.start(config(slave.port()));
  ASSERT_NE(rt, nullptr);
  // Good: the program follows the measurement.
  ASSERT_TRUE(eventually([&] { return channel_value(*rt, "LevelOk") == 1 && channel_value(*rt, "Safe") == 2.5; }))
      << channel_value(*rt, "LevelOk") << " " << channel_value(*rt, "Safe");
  // A channel no driver feeds is never good.
  EXPECT_EQ(channel_value(*rt, "UnfedOk"), 0);

  slave.kill();  // the link goes down: Level keeps its last value, with bad quality
  ASSERT_TRUE(eventually([&] { return channel_value(*rt, "LevelOk") == 0; }));
  EXPECT_TRUE(eventually([&] { return channel_value(*rt, "Safe") == -5; })) << channel_value(*rt, "Safe");
  EXPECT_EQ(channel_value(*rt, "Level"), 2.5);
  // What is computed from the bad input is not good; the fallback the program
  // took is (the status of the branch taken, blocks/status.h).
  EXPECT_TRUE(eventually([&] { return quality_of_label(*rt, "FromLevel") == Quality::kBad; }))
      << quality_name(quality_of_label(*rt, "FromLevel"));
  EXPECT_EQ(quality_of_label(*rt, "Safe"), Quality::kGood);
  // and(Run, good(Level)) is decided by the good 0: a good 0, sent as such.
  EXPECT_EQ(channel_value(*rt, "Enable"), 0);
  EXPECT_EQ(quality_of_label(*rt, "Enable"), Quality::kGood);

  // An operator forcing the bad input vouches for it: the program takes it.
  ASSERT_TRUE(rt->force("Level", 3.0, 0).ok());
  EXPECT_TRUE(eventually([&] { return channel_value(*rt, "LevelOk") == 1 && channel_value(*rt, "Safe") == 3.0; }))
      << channel_value(*rt, "LevelOk") << " " << channel_value(*rt, "Safe");
  ASSERT_TRUE(rt->unforce("Level").ok());
  EXPECT_TRUE(eventually([&] { return channel_value(*rt, "LevelOk") == 0; }));

  slave.put(*modbus::parse_address("hr:0:f32"), 4.0);
  ASSERT_TRUE(slave.restart().ok());
  EXPECT_TRUE(eventually([&] { return channel_value(*rt, "LevelOk") == 1 && channel_value(*rt, "Safe") == 4.0; }))
      << channel_value(*rt, "LevelOk") << " " << channel_value(*rt, "Safe");
  EXPECT_TRUE(eventually([&] { return quality_of_label(*rt, "FromLevel") == Quality::kGood; }));
  rt->stop();
}

TEST(QualityInPrograms, a_silent_slave_makes_what_is_computed_from_it_not_good_within_its_age) {
  modbus::FakeSlave slave;
  ASSERT_TRUE(slave.start().ok());
  slave.put(*modbus::parse_address("hr:0:f32"), 2.5);
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  // A long timeout: the link stays up while the last sample ages past
  // 3 polls, the channel's max age.
  auto rt = fx.start(config(slave.port(), "5s"));
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(eventually([&] { return quality_of_label(*rt, "FromLevel") == Quality::kGood; }));
  ASSERT_EQ(channel_value(*rt, "Enable"), 1);
  slave.set_silent(true);  // the socket stays open, no answer comes
  EXPECT_TRUE(eventually([&] { return quality_of_label(*rt, "Level") == Quality::kStale; }))
      << quality_name(quality_of_label(*rt, "Level"));
  EXPECT_TRUE(eventually([&] { return quality_of_label(*rt, "FromLevel") == Quality::kStale; }))
      << quality_name(quality_of_label(*rt, "FromLevel"));
  EXPECT_TRUE(eventually([&] { return channel_value(*rt, "Enable") == 0; }));
  EXPECT_EQ(quality_of_label(*rt, "Enable"), Quality::kGood) << quality_name(quality_of_label(*rt, "Enable"));
  EXPECT_EQ(quality_of_label(*rt, "Safe"), Quality::kGood);
  rt->stop();
}

TEST(QualityInPrograms, on_bad_policies_are_checked_and_land_in_the_channel_table) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  const std::string base = config(9);  // never started: no slave needed
  std::string errors;
  auto rt = fx.load(base + "    # \n", &errors);
  ASSERT_NE(rt, nullptr) << errors;
  rt.reset();
  const auto with = [&](const std::string& task_keys) {
    std::string y = base;
    y.replace(y.find("program: p.fbd}"), 15, "program: p.fbd, " + task_keys + "}");
    return y;
  };
  errors.clear();
  EXPECT_EQ(fx.load(with("on_bad: {Safe: drop}"), &errors), nullptr);
  EXPECT_NE(errors.find("on_bad of 'Safe' expects hold, safe or send, got 'drop'"), std::string::npos) << errors;
  errors.clear();
  EXPECT_EQ(fx.load(with("on_bad: {Level: safe}"), &errors), nullptr);
  EXPECT_NE(errors.find("task t has no output labelled \"Level\""), std::string::npos) << errors;
  errors.clear();
  rt = fx.load(with("on_bad: {Safe: safe, FromLevel: send}, safe_outputs: {Safe: -2}, watchdog: 3"), &errors);
  ASSERT_NE(rt, nullptr) << errors;
  const io::ChannelDesc& safe = rt->image().channel(static_cast<uint32_t>(rt->image().find_channel("Safe")));
  EXPECT_EQ(safe.on_bad, static_cast<uint8_t>(config::OnBad::kSafe));
  EXPECT_EQ(safe.safe_value, -2);
  const io::ChannelDesc& from = rt->image().channel(static_cast<uint32_t>(rt->image().find_channel("FromLevel")));
  EXPECT_EQ(from.on_bad, static_cast<uint8_t>(config::OnBad::kSend));
  const io::ChannelDesc& ok = rt->image().channel(static_cast<uint32_t>(rt->image().find_channel("LevelOk")));
  EXPECT_EQ(ok.on_bad, static_cast<uint8_t>(config::OnBad::kHold)) << "not listed: hold";
}

}  // namespace
}  // namespace rtplc::sched
