// The epoll engine against the fake PLC on loopback (issue 4, items 3 and 6b):
// values of every area and type, writes acknowledged or failed (never lost), a killed
// PLC reconnected with its items bad then good, blackholed and faulty PLCs costing
// the healthy ones nothing, pipelining over a link slower than the poll period.
// No assertion depends on how fast this machine is: conditions are awaited, and
// "costs nothing" is asserted as "no poll of a healthy PLC was missed".
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>

#include <cstring>
#include <vector>

#include "io/drivers/s7/engine.h"
#include "io/drivers/s7/fake_plc.h"
#include "io/drivers/s7/tests/s7_test_util.h"

namespace rtplc::s7 {
namespace {

using testing::loopback;
using testing::wait_for;

struct Rig {
  explicit Rig(EngineOptions opt = {}) : engine(std::move(opt)) {}
  FakePlc fake;
  Engine engine;
  std::vector<size_t> eps;
  std::vector<PlcId> plcs;

  size_t add_plc(const FakeBehavior& b, uint32_t poll_ms = 50, uint32_t reply_timeout_ms = 1000) {
    FakeEndpointSpec spec;
    spec.address = loopback(static_cast<unsigned>(eps.size()));
    spec.behavior = b;
    auto ep = fake.add_endpoint(spec);
    EXPECT_TRUE(ep.ok()) << ep.error();
    eps.push_back(*ep);
    PlcConfig cfg;
    cfg.address = spec.address;
    cfg.port = fake.port(*ep);
    cfg.poll_period_ms = poll_ms;
    cfg.reply_timeout_ms = reply_timeout_ms;
    cfg.probe_timeout_ms = 300;
    cfg.handshake_timeout_ms = 500 + 3 * b.delay_us / 1000;  // CC and setup each cross the link
    cfg.backoff_min_ms = 50;
    cfg.backoff_max_ms = 400;
    cfg.write_timeout_ms = 2000;
    auto id = engine.connect(cfg);
    EXPECT_TRUE(id.ok()) << id.error();
    plcs.push_back(*id);
    return plcs.size() - 1;
  }

  ItemId item(size_t plc, const char* addr, double scale = 1, double offset = 0) {
    ItemConfig c;
    c.address = *parse_address(addr);
    c.scale = scale;
    c.offset = offset;
    auto id = engine.add_item(plcs[plc], c);
    EXPECT_TRUE(id.ok()) << id.error();
    return *id;
  }

  bool good(ItemId id) const { return engine.read(id).quality == Quality::kGood; }

  void start() {
    ASSERT_TRUE(fake.start().ok());
    ASSERT_TRUE(engine.start().ok());
  }
};

TEST(Engine, reads_every_area_and_type_from_the_fake_plc) {
  Rig rig;
  rig.add_plc(FakeBehavior{});
  const uint8_t db[] = {0x01, 0x02, 0xFF, 0xFE, 0x41, 0x20, 0x00, 0x00, 0x00, 0x00, 0x00, 0x09};
  rig.fake.write_memory(rig.eps[0], Area::kDB, 1, 0, db);
  const uint8_t m[] = {0x0A};
  rig.fake.write_memory(rig.eps[0], Area::kFlags, 0, 3, m);
  const uint8_t i[] = {0x80};
  rig.fake.write_memory(rig.eps[0], Area::kInputs, 0, 0, i);
  const uint8_t q[] = {0x12, 0x34};
  rig.fake.write_memory(rig.eps[0], Area::kOutputs, 0, 2, q);
  const uint8_t c[] = {0x00, 0x2A};
  rig.fake.write_memory(rig.eps[0], Area::kCounters, 0, 4, c);
  const uint8_t t[] = {0x10, 0x05};
  rig.fake.write_memory(rig.eps[0], Area::kTimers, 0, 1, t);

  const ItemId w = rig.item(0, "DB1.DBW0");
  const ItemId n = rig.item(0, "DB1.DBW2:INT");
  const ItemId r = rig.item(0, "DB1.DBD4:REAL");
  const ItemId d = rig.item(0, "DB1.DBD8", 0.5, 1.0);
  const ItemId x = rig.item(0, "DB1.DBX0.0");
  const ItemId mb = rig.item(0, "MB3");
  const ItemId mx = rig.item(0, "M3.1");
  const ItemId ix = rig.item(0, "I0.7");
  const ItemId qw = rig.item(0, "QW2");
  const ItemId cc = rig.item(0, "C4");
  const ItemId tt = rig.item(0, "T1");
  rig.start();
  const std::vector<ItemId> all = {w, n, r, d, x, mb, mx, ix, qw, cc, tt};
  ASSERT_TRUE(wait_for([&] {
    for (ItemId id : all) {
      if (!rig.good(id)) return false;
    }
    return true;
  }));
  EXPECT_EQ(rig.engine.read(w).value, 0x0102);
  EXPECT_EQ(rig.engine.read(n).value, -2);
  EXPECT_EQ(rig.engine.read(r).value, 10.0);
  EXPECT_EQ(rig.engine.read(d).value, 9 * 0.5 + 1.0);
  EXPECT_EQ(rig.engine.read(x).value, 1);
  EXPECT_EQ(rig.engine.read(mb).value, 10);
  EXPECT_EQ(rig.engine.read(mx).value, 1);
  EXPECT_EQ(rig.engine.read(ix).value, 1);
  EXPECT_EQ(rig.engine.read(qw).value, 0x1234);
  EXPECT_EQ(rig.engine.read(cc).raw, 42u);
  EXPECT_EQ(rig.engine.read(tt).raw, 0x1005u);
  // Eleven items, one PDU (the status is published at most every 250 ms).
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).requests_per_poll == 1; }));
  EXPECT_EQ(rig.engine.status(rig.plcs[0]).state, PlcState::kReady);
}

TEST(Engine, acknowledges_writes_and_the_plc_holds_the_values) {
  Rig rig;
  rig.add_plc(FakeBehavior{});
  const ItemId w = rig.item(0, "DB2.DBW10:INT");
  const ItemId r = rig.item(0, "DB2.DBD12:REAL");
  const ItemId b = rig.item(0, "Q1.3");
  const ItemId s = rig.item(0, "MW20", 0.1);  // engineering value 12.3 -> raw 123
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.good(w) && rig.good(s); }));
  const WriteTicket t1 = rig.engine.write(w, -300);
  const WriteTicket t2 = rig.engine.write(r, 2.5);
  const WriteTicket t3 = rig.engine.write(b, 1);
  const WriteTicket t4 = rig.engine.write(s, 12.3);
  for (WriteTicket t : {t1, t2, t3, t4}) {
    ASSERT_TRUE(wait_for([&] { return rig.engine.write_result(t).state != WriteState::kPending; }));
    EXPECT_EQ(rig.engine.write_result(t).state, WriteState::kAcknowledged);
  }
  EXPECT_EQ(rig.fake.read_memory(rig.eps[0], Area::kDB, 2, 10, 2), (Bytes{0xFE, 0xD4}));
  EXPECT_EQ(rig.fake.read_memory(rig.eps[0], Area::kDB, 2, 12, 4), (Bytes{0x40, 0x20, 0x00, 0x00}));
  EXPECT_EQ(rig.fake.read_memory(rig.eps[0], Area::kOutputs, 0, 1, 1), (Bytes{0x08}));
  EXPECT_EQ(rig.fake.read_memory(rig.eps[0], Area::kFlags, 0, 20, 2), (Bytes{0x00, 123}));
  ASSERT_TRUE(wait_for([&] { return rig.engine.read(w).value == -300; }));
  ASSERT_TRUE(wait_for([&] { return rig.engine.read(s).value > 12.29 && rig.engine.read(s).value < 12.31; }));
  const EngineCounters c = rig.engine.counters();
  EXPECT_EQ(c.writes_queued, 4u);
  EXPECT_EQ(c.writes_acked, 4u);
}

// A value the item cannot hold (after scale and offset) fails without being
// sent: 40000 used to be clamped to 32767 and acknowledged.
TEST(Engine, fails_a_value_its_item_cannot_hold_instead_of_clamping_it) {
  Rig rig;
  rig.add_plc(FakeBehavior{});
  const ItemId i = rig.item(0, "DB2.DBW10:INT");
  const ItemId scaled = rig.item(0, "DB2.DBB12", 0.1);  // raw = value / 0.1
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.good(i) && rig.good(scaled); }));
  const uint8_t marker[] = {0x12, 0x34, 0x56};
  rig.fake.write_memory(rig.eps[0], Area::kDB, 2, 10, marker);
  for (const auto& [item, value] : {std::pair{i, 40000.0}, std::pair{i, -32769.0}, std::pair{i, std::nan("")},
                                    std::pair{scaled, 25.6}}) {
    const WriteTicket t = rig.engine.write(item, value);
    ASSERT_TRUE(wait_for([&] { return rig.engine.write_result(t).state != WriteState::kPending; }));
    EXPECT_EQ(rig.engine.write_result(t).state, WriteState::kFailed) << value;
  }
  EXPECT_EQ(rig.fake.read_memory(rig.eps[0], Area::kDB, 2, 10, 3), (Bytes{0x12, 0x34, 0x56}));
  // The status says why (it is published every 250 ms).
  EXPECT_TRUE(wait_for([&] {
    return std::string(rig.engine.status(rig.plcs[0]).last_error).find("out of range for BYTE (0..255)") !=
           std::string::npos;
  })) << rig.engine.status(rig.plcs[0]).last_error;
  const WriteTicket ok = rig.engine.write(scaled, 25.5);
  ASSERT_TRUE(wait_for([&] { return rig.engine.write_result(ok).state != WriteState::kPending; }));
  EXPECT_EQ(rig.engine.write_result(ok).state, WriteState::kAcknowledged);
  EXPECT_EQ(rig.fake.read_memory(rig.eps[0], Area::kDB, 2, 12, 1), Bytes{255});
}

TEST(Engine, fails_a_write_the_plc_refuses_and_one_it_never_gets) {
  Rig rig;
  rig.add_plc(FakeBehavior{});
  FakeBehavior dead;
  dead.blackhole = FakeBehavior::Blackhole::kNeverAccept;
  rig.add_plc(dead);
  const ItemId missing = rig.item(0, "DB99.DBW0");  // no DB99 in the fake
  const ItemId unreachable = rig.item(1, "DB1.DBW0");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).state == PlcState::kReady; }));
  const WriteTicket refused = rig.engine.write(missing, 1);
  const WriteTicket lost = rig.engine.write(unreachable, 1);
  EXPECT_EQ(rig.engine.write_result(lost).state, WriteState::kPending);
  ASSERT_TRUE(wait_for([&] { return rig.engine.write_result(refused).state != WriteState::kPending; }));
  EXPECT_EQ(rig.engine.write_result(refused).state, WriteState::kFailed);
  EXPECT_EQ(rig.engine.write_result(refused).return_code, 0x0A);
  ASSERT_TRUE(wait_for([&] { return rig.engine.write_result(lost).state != WriteState::kPending; }));
  EXPECT_EQ(rig.engine.write_result(lost).state, WriteState::kFailed);
  EXPECT_EQ(rig.engine.counters().writes_failed, 2u);
  // The refused item reads as bad with the PLC's reason.
  ASSERT_TRUE(wait_for([&] { return rig.engine.read(missing).return_code == 0x0A; }));
  EXPECT_EQ(rig.engine.read(missing).quality, Quality::kBad);
}

TEST(Engine, reconnects_a_killed_plc_and_its_items_go_bad_then_good) {
  Rig rig;
  rig.add_plc(FakeBehavior{});
  const uint8_t v[] = {0x00, 0x07};
  rig.fake.write_memory(rig.eps[0], Area::kDB, 1, 0, v);
  const ItemId w = rig.item(0, "DB1.DBW0");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.good(w); }));
  rig.fake.kill(rig.eps[0]);
  ASSERT_TRUE(wait_for([&] { return rig.engine.read(w).quality == Quality::kBad; }));
  EXPECT_EQ(rig.engine.read(w).value, 7);  // the last value is kept
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).connect_failures > 0; }));
  const uint8_t v2[] = {0x00, 0x08};
  rig.fake.write_memory(rig.eps[0], Area::kDB, 1, 0, v2);
  rig.fake.restart(rig.eps[0]);
  ASSERT_TRUE(wait_for([&] { return rig.good(w) && rig.engine.read(w).value == 8; }));
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).connects >= 2; }));
  EXPECT_GE(rig.engine.status(rig.plcs[0]).reconnects, 1u);
}

TEST(Engine, marks_values_stale_when_fresh_ones_stop_coming) {
  Rig rig;
  rig.add_plc(FakeBehavior{}, 50, 5000);
  const ItemId w = rig.item(0, "MW0");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.good(w); }));
  FakeBehavior silent;
  silent.blackhole = FakeBehavior::Blackhole::kAcceptSilent;
  rig.fake.set_behavior(rig.eps[0], silent);
  const Sample s = rig.engine.read(w);
  EXPECT_EQ(s.quality_at(s.timestamp_ns + s.max_age_ns / 2), Quality::kGood);
  EXPECT_EQ(s.quality_at(s.timestamp_ns + s.max_age_ns + 1), Quality::kStale);
}

// Healthy PLCs beside a never-accepting, a silent and three faulty ones: each healthy
// PLC completes its polls with none missed and never reconnects.
TEST(Engine, keeps_serving_healthy_plcs_beside_dead_and_faulty_ones) {
  Rig rig;
  FakeBehavior healthy;
  healthy.delay_us = 20'000;
  FakeBehavior never;
  never.blackhole = FakeBehavior::Blackhole::kNeverAccept;
  FakeBehavior silent;
  silent.blackhole = FakeBehavior::Blackhole::kAcceptSilent;
  FakeBehavior cut;
  cut.p_disconnect_mid_reply = 0.2;
  FakeBehavior wrong;
  wrong.p_wrong_ref = 0.2;
  FakeBehavior garbage;
  garbage.p_malformed = 0.2;
  std::vector<size_t> good_ones;
  for (int i = 0; i < 3; ++i) good_ones.push_back(rig.add_plc(healthy, 100));
  const size_t n = rig.add_plc(never, 100);
  const size_t s = rig.add_plc(silent, 100);
  const size_t c = rig.add_plc(cut, 100, 300);
  const size_t w = rig.add_plc(wrong, 100, 300);
  const size_t g = rig.add_plc(garbage, 100, 300);
  std::vector<ItemId> healthy_items;
  for (size_t p = 0; p < rig.plcs.size(); ++p) {
    for (int k = 0; k < 10; ++k) {
      const ItemId id = rig.item(p, fmt::format("DB1.DBW{}", k * 2).c_str());
      if (p < 3) healthy_items.push_back(id);
    }
  }
  rig.start();
  auto completed = [&](size_t p) { return rig.engine.status(rig.plcs[p]).polls_completed; };
  ASSERT_TRUE(wait_for([&] { return completed(0) > 0 && completed(1) > 0 && completed(2) > 0; }));
  std::vector<PlcStatus> before;
  for (size_t p : good_ones) before.push_back(rig.engine.status(rig.plcs[p]));
  // Watch 20 polls of every healthy PLC while the others fail around them.
  ASSERT_TRUE(wait_for([&] {
    for (size_t p : good_ones) {
      if (completed(p) < before[p].polls_completed + 20) return false;
    }
    return true;
  }));
  for (size_t p : good_ones) {
    const PlcStatus st = rig.engine.status(rig.plcs[p]);
    EXPECT_EQ(st.polls_missed, before[p].polls_missed) << "PLC " << p;
    EXPECT_EQ(st.connects, 1u) << "PLC " << p;
    EXPECT_EQ(st.reconnects, 0u) << "PLC " << p;
    EXPECT_EQ(st.timeouts, 0u) << "PLC " << p;
  }
  for (ItemId id : healthy_items) EXPECT_EQ(rig.engine.read(id).quality, Quality::kGood);
  // And the faulty ones were noticed for what they are.
  ASSERT_TRUE(wait_for([&] {
    return rig.engine.status(rig.plcs[n]).connect_failures > 0 && rig.engine.status(rig.plcs[s]).connect_failures > 0 &&
           rig.engine.status(rig.plcs[c]).reconnects > 0 && rig.engine.status(rig.plcs[w]).dropped_replies > 0 &&
           rig.engine.status(rig.plcs[g]).errors > 0;
  }));
  EXPECT_EQ(rig.engine.status(rig.plcs[n]).connects, 0u);
  EXPECT_EQ(rig.engine.status(rig.plcs[s]).connects, 0u);
  EXPECT_GT(rig.engine.status(rig.plcs[w]).timeouts, 0u);
}

// A link slower than the poll period: 250 ms delay, 50 ms polls, AmQ 8. Requests are
// pipelined, so no poll is missed although each takes five periods.
TEST(Engine, pipelines_polls_over_a_link_slower_than_the_period) {
  Rig rig;
  FakeBehavior slow;
  slow.delay_us = 250'000;
  slow.max_amq = 8;
  rig.add_plc(slow, 50, 2000);
  rig.item(0, "DB1.DBW0");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).polls_completed > 0; }));
  const PlcStatus before = rig.engine.status(rig.plcs[0]);
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).polls_completed >= before.polls_completed + 20; }));
  const PlcStatus after = rig.engine.status(rig.plcs[0]);
  EXPECT_EQ(after.amq, 8);
  EXPECT_EQ(after.polls_missed, before.polls_missed);
  EXPECT_EQ(after.reconnects, 0u);
  EXPECT_GE(after.rtt_p50_us, 250'000u);
}

// With AmQ 1 the same link cannot keep up: the engine counts missed polls instead of
// queueing them without bound.
TEST(Engine, counts_missed_polls_when_amq_one_cannot_keep_up) {
  Rig rig;
  FakeBehavior slow;
  slow.delay_us = 150'000;
  slow.max_amq = 1;
  rig.add_plc(slow, 50, 2000);
  rig.item(0, "DB1.DBW0");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).polls_completed >= 3; }));
  const PlcStatus st = rig.engine.status(rig.plcs[0]);
  EXPECT_EQ(st.amq, 1);
  EXPECT_GT(st.polls_missed, 0u);
}

TEST(Engine, stops_reading_removed_items_and_plcs) {
  Rig rig;
  rig.add_plc(FakeBehavior{});
  const ItemId a = rig.item(0, "MW0");
  const ItemId b = rig.item(0, "MW100");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.good(a) && rig.good(b); }));
  rig.engine.remove_item(b);
  ASSERT_TRUE(wait_for([&] { return rig.engine.read(b).timestamp_ns == 0; }));
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).items == 1; }));
  rig.engine.disconnect(rig.plcs[0]);
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).state == PlcState::kUnused; }));
  EXPECT_EQ(rig.engine.read(a).quality, Quality::kBad);
  ASSERT_TRUE(wait_for([&] { return rig.fake.connections(rig.eps[0]) == 0; }));
}

// With wakeup coalescing the loop sleeps instead of waiting in epoll while traffic
// flows: everything still arrives, only later by at most the coalescing period.
TEST(Engine, serves_reads_writes_and_faults_with_wakeup_coalescing) {
  EngineOptions opt;
  opt.coalesce_us = 2000;
  Rig rig(opt);
  FakeBehavior healthy;
  healthy.delay_us = 5000;
  rig.add_plc(healthy, 50);
  FakeBehavior never;
  never.blackhole = FakeBehavior::Blackhole::kNeverAccept;
  rig.add_plc(never, 50);
  const ItemId w = rig.item(0, "DB1.DBW0:INT");
  rig.item(1, "DB1.DBW0");
  rig.start();
  ASSERT_TRUE(wait_for([&] { return rig.good(w); }));
  const WriteTicket t = rig.engine.write(w, -42);
  ASSERT_TRUE(wait_for([&] { return rig.engine.write_result(t).state == WriteState::kAcknowledged; }));
  ASSERT_TRUE(wait_for([&] { return rig.engine.read(w).value == -42; }));
  const PlcStatus before = rig.engine.status(rig.plcs[0]);
  ASSERT_TRUE(wait_for([&] { return rig.engine.status(rig.plcs[0]).polls_completed >= before.polls_completed + 20; }));
  EXPECT_EQ(rig.engine.status(rig.plcs[0]).polls_missed, before.polls_missed);
  EXPECT_GT(rig.engine.status(rig.plcs[1]).connect_failures, 0u);
}

TEST(Engine, rejects_bad_setup_calls_with_clear_errors) {
  Engine engine;
  PlcConfig cfg;
  cfg.address = "plc.example";
  EXPECT_NE(engine.connect(cfg).error().find("IPv4"), std::string::npos);
  EXPECT_FALSE(engine.add_item(12345, ItemConfig{}).ok());
  EXPECT_EQ(engine.write_result(WriteTicket{}).state, WriteState::kRejected);
  EXPECT_EQ(engine.write(kNoId, 1).id, 0u);
}

}  // namespace
}  // namespace rtplc::s7
