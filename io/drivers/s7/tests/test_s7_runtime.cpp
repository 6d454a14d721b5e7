// The s7 driver wired into the runtime (issue "S7 multi-PLC client", item 5),
// against the fake PLC: era reads land in the process image with quality, ewa
// and ewd writes reach the PLC and are acknowledged, a PLC that dies turns its
// channels bad (last value kept) and good again when it comes back, and writes
// made while it was gone are sent once it is back — none silently lost; a
// restarted PLC gets our unchanged outputs again, an output's delivery is bad
// while it cannot reach its PLC, a REAL holding NaN reads bad, a value that does
// not fit its item is refused rather than clamped, and the link events reach
// the runtime's log (drained by tick()).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "io/drivers/s7/address.h"
#include "io/drivers/s7/fake_plc.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/eventually.h"

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

using rtplc::testing::eventually;

// The runtime of every test here: plc1 on the fake PLC; F1 read from
// DB10.DBD0:REAL, F2 = 2 * F1 + 1 written to DB10.DBD4:REAL, an operator bit to
// DB10.DBX8.0; the tests add programs lines and channel maps of their own.
struct Extra {
  std::string program;  // more FBD lines
  std::string writes;   // more `write:` entries
  std::string plcs;     // more `plcs:` entries
};

class S7Runtime : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(plc_.add_endpoint({"127.0.0.1", 0, {}}).ok());
    ASSERT_TRUE(plc_.start().ok());
    write_real(plc_, 0, 2.5f);
  }
  void start(const Extra& extra = {}) {
    fx_.write("p.fbd",
              "%%\nstime(0.02)\nF1 = era(p1, d0, c0, \"Volt\")\nF2 = scale(F1, 2, 1)\n"
              "D3 = dsp(d1, c1, 1, \"Enable\")\newa(F2, p1, d0, c1, \"Out\")\newd(D3, p1, d0, c2, \"Bit\")\n" +
                  extra.program + "END\n");
    const std::string port = std::to_string(plc_.port(0));
    rt_ = fx_.start(
        "tasks:\n  - {name: t, program: p.fbd}\n"
        "drivers:\n  - kind: s7\n    name: s7\n    period: 10ms\n    plcs:\n"
        "      - {name: plc1, address: 127.0.0.1, port: " + port + ", poll: 20ms, reply_timeout: 200ms}\n" +
        extra.plcs +
        "    read:\n      - {channel: p1.d0.c0, plc: plc1, item: DB10.DBD0:REAL}\n"
        "    write:\n      - {channel: p1.d0.c1, plc: plc1, item: DB10.DBD4:REAL}\n"
        "      - {channel: p1.d0.c2, plc: plc1, item: DB10.DBX8.0}\n" + extra.writes);
    ASSERT_NE(rt_, nullptr);
  }
  void TearDown() override {
    if (rt_) rt_->stop();
    plc_.stop();
  }
  io::ChannelValue channel(const char* label) {
    return rt_->image().read_channel(static_cast<uint32_t>(rt_->image().find_channel(label)));
  }
  // What the control thread does: drains the drivers' events into the log.
  void drain_log() {
    rt_->tick([&](bool, const std::string& line) { log_.push_back(line); });
  }
  size_t log_count(const std::string& part) {
    drain_log();
    return static_cast<size_t>(
        std::count_if(log_.begin(), log_.end(), [&](const std::string& l) { return l.find(part) != std::string::npos; }));
  }
  std::string log_text() const {
    std::string all;
    for (const std::string& l : log_) all += l + "\n";
    return all;
  }

  s7::FakePlc plc_;
  RuntimeFixture fx_;
  std::unique_ptr<Runtime> rt_;
  std::vector<std::string> log_;
};

TEST_F(S7Runtime, values_flow_from_the_plc_through_the_task_back_to_the_plc) {
  start();
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
  start();
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

// A PLC restart loses its values: our outputs did not change, so only the
// reconnect (a new session in the `connects` counter) can send them again.
TEST_F(S7Runtime, a_restarted_plc_gets_our_unchanged_outputs_again) {
  start();
  ASSERT_TRUE(eventually([&] { return read_real(plc_, 4) == 6.0f; }));
  ASSERT_TRUE(eventually([&] { return (plc_.read_memory(0, s7::Area::kDB, 10, 8, 1)[0] & 1) != 0; }));
  plc_.kill(0);
  ASSERT_TRUE(eventually([&] { return channel("Volt").quality != Quality::kGood; }));
  // The PLC comes back with its memory reset; the read input stays 2.5.
  const uint8_t zeros[5] = {};
  plc_.write_memory(0, s7::Area::kDB, 10, 4, zeros);
  plc_.restart(0);
  EXPECT_TRUE(eventually([&] { return read_real(plc_, 4) == 6.0f; })) << "PLC holds " << read_real(plc_, 4);
  EXPECT_TRUE(eventually([&] { return (plc_.read_memory(0, s7::Area::kDB, 10, 8, 1)[0] & 1) != 0; }));
}

// The monitor shows an output as the worse of the task's quality and the
// driver's delivery: bad while its PLC is gone, though the task is fine.
TEST_F(S7Runtime, an_output_reads_bad_while_its_plc_is_down_and_good_once_back) {
  start();
  // Out = 2 * Volt + 1 is delivered (good) from the first cycles on, as 1 until
  // the first read of Volt (2.5) reaches the task: wait for the value too.
  ASSERT_TRUE(eventually([&] {
    const io::ChannelValue out = channel("Out");
    return out.quality == Quality::kGood && out.value == 6.0;
  })) << int(channel("Out").quality) << " " << channel("Out").value;
  plc_.kill(0);
  EXPECT_TRUE(eventually([&] { return channel("Out").quality == Quality::kBad; })) << int(channel("Out").quality);
  EXPECT_TRUE(eventually([&] { return channel("Bit").quality == Quality::kBad; }));
  sleep_s(0.3);
  EXPECT_EQ(channel("Out").quality, Quality::kBad);  // and stays so
  plc_.restart(0);
  EXPECT_TRUE(eventually([&] { return channel("Out").quality == Quality::kGood; })) << int(channel("Out").quality);
  EXPECT_TRUE(eventually([&] { return channel("Bit").quality == Quality::kGood; }));
}

TEST_F(S7Runtime, a_real_holding_nan_reads_bad) {
  start();
  ASSERT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kGood; }));
  const uint8_t nan[4] = {0x7F, 0xC0, 0x00, 0x00};
  plc_.write_memory(0, s7::Area::kDB, 10, 0, nan);
  EXPECT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kBad; })) << channel("Volt").value;
  sleep_s(0.2);
  EXPECT_EQ(channel("Volt").quality, Quality::kBad);
  const uint8_t inf[4] = {0xFF, 0x80, 0x00, 0x00};
  plc_.write_memory(0, s7::Area::kDB, 10, 0, inf);
  sleep_s(0.2);
  EXPECT_EQ(channel("Volt").quality, Quality::kBad);
  write_real(plc_, 0, 1.0f);
  EXPECT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kGood && channel("Volt").value == 1.0; }));
}

// 40000 to an INT item used to arrive as 32767 and look delivered.
TEST_F(S7Runtime, an_output_that_does_not_fit_its_int_item_is_refused_not_clamped) {
  start({"F4 = scale(F1, 1000, 0)\newa(F4, p1, d0, c3, \"Big\")\n",
         "      - {channel: p1.d0.c3, plc: plc1, item: DB10.DBW12:INT}\n", ""});
  write_real(plc_, 0, 12.0f);
  auto int_at_12 = [&] {
    const s7::Bytes b = plc_.read_memory(0, s7::Area::kDB, 10, 12, 2);
    return static_cast<int16_t>(static_cast<uint16_t>(b[0] << 8 | b[1]));
  };
  ASSERT_TRUE(eventually([&] { return int_at_12() == 12000; })) << int_at_12();
  ASSERT_TRUE(eventually([&] { return channel("Big").quality == Quality::kGood; }));
  const uint64_t failed_before = rt_->image().link(0).writes_failed.load();
  write_real(plc_, 0, 40.0f);  // 40000
  EXPECT_TRUE(eventually([&] { return channel("Big").quality == Quality::kBad; }));
  EXPECT_TRUE(eventually([&] { return log_count("does not fit INT (-32768..32767)") == 1; })) << log_text();
  EXPECT_TRUE(eventually([&] { return rt_->image().link(0).writes_failed.load() == failed_before + 1; }));
  sleep_s(0.3);
  EXPECT_EQ(int_at_12(), 12000);  // the PLC keeps what it had
  EXPECT_EQ(channel("Big").quality, Quality::kBad);
  EXPECT_EQ(log_count("does not fit INT"), 1u) << log_text();               // once per item
  EXPECT_EQ(rt_->image().link(0).writes_failed.load(), failed_before + 1);  // once per value
  write_real(plc_, 0, -20.0f);
  EXPECT_TRUE(eventually([&] { return int_at_12() == -20000; })) << int_at_12();
  EXPECT_TRUE(eventually([&] { return channel("Big").quality == Quality::kGood; }));
}

TEST_F(S7Runtime, link_down_and_up_reach_the_log) {
  start();
  ASSERT_TRUE(eventually([&] { return log_count("PLC plc1 connected") == 1; })) << log_text();
  plc_.kill(0);
  // Within seconds of the first message: the rate limit lets the first few through.
  EXPECT_TRUE(eventually([&] { return log_count("PLC plc1 disconnected") == 1; })) << log_text();
  plc_.restart(0);
  EXPECT_TRUE(eventually([&] { return log_count("PLC plc1 connected") == 2; })) << log_text();
}

TEST_F(S7Runtime, a_flapping_link_is_rate_limited_and_its_last_state_is_logged) {
  start();
  ASSERT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kGood; }));
  for (int i = 0; i < 4; ++i) {
    plc_.kill(0);
    ASSERT_TRUE(eventually([&] { return channel("Volt").quality != Quality::kGood; }));
    plc_.restart(0);
    ASSERT_TRUE(eventually([&] { return channel("Volt").quality == Quality::kGood; }));
  }
  plc_.kill(0);
  // Nine changes: the first messages at once (a message may sum up two changes
  // seen between two looks), then the limit holds the rest back and sums them up
  // in one message once it allows, which ends on the link's state: down.
  ASSERT_TRUE(eventually([&] { return log_count("PLC plc1 ") >= 5; }, 15)) << log_text();
  sleep_s(0.5);
  EXPECT_EQ(log_count("PLC plc1 "), 5u) << log_text();
  EXPECT_NE(log_.back().find("PLC plc1 disconnected"), std::string::npos) << log_text();
  EXPECT_NE(log_.back().find("link changes since the last message"), std::string::npos) << log_text();
}

TEST_F(S7Runtime, a_write_the_plc_refuses_is_logged_once_with_the_return_code) {
  // The fake PLC has DB1..DB16: DB99 does not exist.
  start({"ewa(F2, p1, d0, c3, \"Nowhere\")\n", "      - {channel: p1.d0.c3, plc: plc1, item: DB99.DBW0}\n", ""});
  const std::string refused = "item DB99.DBW0: write refused by the PLC: object does not exist (no such DB or area) (0x0A)";
  ASSERT_TRUE(eventually([&] { return log_count(refused) == 1; })) << log_text();
  EXPECT_TRUE(eventually([&] { return channel("Nowhere").quality == Quality::kBad; }));
  // A new value and a reconnect send it again; it is refused again, not logged again.
  write_real(plc_, 0, 3.0f);
  plc_.drop_connections(0);
  EXPECT_TRUE(eventually([&] { return log_count("PLC plc1 connected") == 2; })) << log_text();
  sleep_s(0.5);
  EXPECT_EQ(log_count("write refused"), 1u) << log_text();
  EXPECT_GE(rt_->image().link(0).writes_failed.load(), 2u);
  EXPECT_EQ(channel("Nowhere").quality, Quality::kBad);
  EXPECT_EQ(channel("Out").quality, Quality::kGood);  // the other outputs are not affected
}

TEST_F(S7Runtime, a_plc_where_nothing_listens_is_logged_unreachable_at_start) {
  auto ep = plc_.add_endpoint({"127.0.0.1", 0, {}});
  ASSERT_TRUE(ep.ok());
  const std::string port = std::to_string(plc_.port(*ep));
  plc_.kill(*ep);  // the port refuses connections now
  start({"", "", "      - {name: plc2, address: 127.0.0.1, port: " + port + ", poll: 20ms}\n"});
  EXPECT_TRUE(eventually([&] { return log_count("PLC plc2 (127.0.0.1:" + port + ") unreachable at start") == 1; }))
      << log_text();
  sleep_s(0.5);
  EXPECT_EQ(log_count("unreachable at start"), 1u) << log_text();
  EXPECT_EQ(log_count("PLC plc2 disconnected"), 0u) << log_text();  // never up: no down
  EXPECT_EQ(log_count("PLC plc1 connected"), 1u) << log_text();
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
