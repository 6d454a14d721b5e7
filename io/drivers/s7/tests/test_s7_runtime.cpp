// The s7 driver wired into the runtime (issue "S7 multi-PLC client", item 5),
// against the fake PLC: era reads land in the process image with quality, ewa
// and ewd writes reach the PLC and are acknowledged, a PLC that dies turns its
// channels bad (last value kept) and good again when it comes back, and writes
// made while it was gone are sent once it is back — none silently lost.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "io/drivers/s7/address.h"
#include "io/drivers/s7/fake_plc.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

float read_real(const s7::FakePlc& plc, uint32_t offset) {
  const s7::Bytes b = plc.read_memory(0, s7::Area::kDB, 10, offset, 4);
  const uint32_t raw = uint32_t{b[0]} << 24 | uint32_t{b[1]} << 16 | uint32_t{b[2]} << 8 | b[3];
  float f;
  std::memcpy(&f, &raw, 4);
  return f;
}

void write_real(s7::FakePlc& plc, uint32_t offset, float v) {
  uint32_t raw;
  std::memcpy(&raw, &v, 4);
  const uint8_t b[4] = {static_cast<uint8_t>(raw >> 24), static_cast<uint8_t>(raw >> 16),
                        static_cast<uint8_t>(raw >> 8), static_cast<uint8_t>(raw)};
  plc.write_memory(0, s7::Area::kDB, 10, offset, b);
}

template <class F>
bool eventually(F f, double seconds = 5) {
  for (int i = 0; i < static_cast<int>(seconds * 50); ++i) {
    if (f()) return true;
    sleep_s(0.02);
  }
  return f();
}

class S7Runtime : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(plc_.add_endpoint({"127.0.0.1", 0, {}}).ok());
    ASSERT_TRUE(plc_.start().ok());
    write_real(plc_, 0, 2.5f);
    fx_.write("p.fbd",
              "%%\nstime(0.02)\nF1 = era(p1, d0, c0, \"Volt\")\nF2 = scale(F1, 2, 1)\n"
              "D3 = dsp(d1, c1, 1, \"Enable\")\newa(F2, p1, d0, c1, \"Out\")\newd(D3, p1, d0, c2, \"Bit\")\nEND\n");
    const std::string port = std::to_string(plc_.port(0));
    rt_ = fx_.start(
        "tasks:\n  - {name: t, program: p.fbd}\n"
        "drivers:\n  - kind: s7\n    name: s7\n    period: 10ms\n    plcs:\n"
        "      - {name: plc1, address: 127.0.0.1, port: " + port + ", poll: 20ms, reply_timeout: 200ms}\n"
        "    read:\n      - {channel: p1.d0.c0, plc: plc1, item: DB10.DBD0:REAL}\n"
        "    write:\n      - {channel: p1.d0.c1, plc: plc1, item: DB10.DBD4:REAL}\n"
        "      - {channel: p1.d0.c2, plc: plc1, item: DB10.DBX8.0}\n");
    ASSERT_NE(rt_, nullptr);
  }
  void TearDown() override {
    if (rt_) rt_->stop();
    plc_.stop();
  }
  io::ChannelValue channel(const char* label) {
    return rt_->image().read_channel(static_cast<uint32_t>(rt_->image().find_channel(label)));
  }

  s7::FakePlc plc_;
  RuntimeFixture fx_;
  std::unique_ptr<Runtime> rt_;
};

TEST_F(S7Runtime, values_flow_from_the_plc_through_the_task_back_to_the_plc) {
  ASSERT_TRUE(eventually([&] { return read_real(plc_, 4) == 6.0f; }))  // 2.5 * 2 + 1
      << "PLC holds " << read_real(plc_, 4);
  const io::ChannelValue v = channel("Volt");
  EXPECT_EQ(v.value, 2.5);
  EXPECT_EQ(v.quality, Quality::kGood);
  EXPECT_TRUE(eventually([&] { return plc_.read_memory(0, s7::Area::kDB, 10, 8, 1)[0] & 1; }));
  write_real(plc_, 0, -1.0f);
  EXPECT_TRUE(eventually([&] { return read_real(plc_, 4) == -1.0f; }));
  // The operator switches the bit off: it reaches the PLC.
  ASSERT_TRUE(rt_->set_value("Enable", 0).ok());
  EXPECT_TRUE(eventually([&] { return (plc_.read_memory(0, s7::Area::kDB, 10, 8, 1)[0] & 1) == 0; }));
  // The link table (published every 250 ms) counts the acknowledged writes.
  const io::LinkStatus& ls = rt_->image().link(0);
  EXPECT_TRUE(eventually([&] { return ls.writes_acked.load() > 2u; }));
  EXPECT_EQ(ls.writes_failed.load(), 0u);
  EXPECT_EQ(ls.state.load(), static_cast<uint8_t>(io::LinkState::kUp));
}

TEST_F(S7Runtime, a_plc_that_dies_turns_bad_keeping_its_value_and_recovers) {
  ASSERT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kGood; }));
  plc_.kill(0);
  ASSERT_TRUE(eventually([&] { return channel("Volt").quality != Quality::kGood; }));
  EXPECT_EQ(channel("Volt").value, 2.5);  // the last value stays
  // A write made while the PLC is gone is kept, not lost ...
  write_real(plc_, 0, 7.0f);              // (the PLC's own memory; it is down)
  ASSERT_TRUE(rt_->set_value("Enable", 0).ok());
  sleep_s(0.3);
  plc_.restart(0);
  // ... and arrives once the PLC is back; the read value follows too.
  EXPECT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kGood && channel("Volt").value == 7.0; }));
  EXPECT_TRUE(eventually([&] { return (plc_.read_memory(0, s7::Area::kDB, 10, 8, 1)[0] & 1) == 0; }));
  EXPECT_TRUE(eventually([&] { return read_real(plc_, 4) == 15.0f; }));
  EXPECT_GE(rt_->image().link(0).reconnects.load() + rt_->image().link(0).connects.load(), 2u);
}

TEST(S7RuntimeConfig, a_write_map_without_a_task_output_is_refused) {
  RuntimeFixture fx;
  fx.write("p.fbd", "%%\nF1 = era(p1, d0, c0, \"Volt\")\nEND\n");
  std::string errors;
  auto rt = fx.load(
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: s7\n    plcs: [{name: a, address: 127.0.0.1}]\n"
      "    write: [{channel: p1.d0.c5, plc: a, item: MW0}]\n"
      "    read: [{channel: p1.d0.c0, plc: a, item: 'DB1.DBX'}]\n",
      &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("bad S7 item 'DB1.DBX'"), std::string::npos) << errors;
  errors.clear();
  rt = fx.load(
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: s7\n    plcs: [{name: a, address: 127.0.0.1}]\n"
      "    write: [{channel: p1.d0.c5, plc: a, item: MW0}]\n",
      &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("no task writes out/ETH/p1.d0.c5, which driver s7 sends"), std::string::npos) << errors;
  errors.clear();
  rt = fx.load(
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: s7\n    plcs: [{name: a, address: plc.example}]\n", &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("numeric IPv4"), std::string::npos) << errors;
}

}  // namespace
}  // namespace rtplc::sched
