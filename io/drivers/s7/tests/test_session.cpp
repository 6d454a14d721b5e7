// The blocking commissioning session against the fake PLC: reads and writes of
// every area, the PLC's item errors passed through, clear errors when nobody
// answers (issue 4, item 4).
#include <gtest/gtest.h>

#include "io/drivers/s7/fake_plc.h"
#include "io/drivers/s7/session.h"
#include "io/drivers/s7/tests/s7_test_util.h"

namespace rtplc::s7 {
namespace {

std::vector<ItemAddress> parse_all(std::initializer_list<const char*> texts) {
  std::vector<ItemAddress> out;
  for (const char* t : texts) out.push_back(*parse_address(t));
  return out;
}

struct SessionRig {
  FakePlc fake;
  size_t ep = 0;
  SessionOptions opt;

  explicit SessionRig(FakeBehavior b = {}) {
    FakeEndpointSpec spec;
    spec.address = testing::loopback(0);
    spec.behavior = b;
    ep = *fake.add_endpoint(spec);
    EXPECT_TRUE(fake.start().ok());
    opt.host = spec.address;
    opt.port = fake.port(ep);
    opt.connect_timeout_ms = 2000;
    opt.reply_timeout_ms = 2000;
  }
};

TEST(Session, writes_then_reads_every_area) {
  SessionRig rig;
  Session s;
  ASSERT_TRUE(s.connect(rig.opt).ok());
  EXPECT_EQ(s.info().negotiated.pdu_size, 480);
  const auto items = parse_all({"DB1.DBX0.0", "DB1.DBB2", "DB1.DBW4", "DB1.DBD8", "DB1.DBD12:REAL", "MB3", "MW4",
                                "M0.1", "IB0", "IW2", "I4.0", "QB0", "Q1.1", "C0", "T0", "DB1.DBW16:INT"});
  std::vector<uint64_t> raws;
  for (const ItemAddress& a : items) {
    const char* text = a.type == DataType::kBool ? "1" : a.type == DataType::kReal ? "-1.5" : a.type == DataType::kInt ? "-7" : "77";
    raws.push_back(*parse_value(a.type, text));
  }
  auto w = s.write(items, raws);
  ASSERT_TRUE(w.ok()) << w.error();
  for (size_t i = 0; i < items.size(); ++i) EXPECT_TRUE((*w)[i].ok()) << format_address(items[i]);
  auto r = s.read(items);
  ASSERT_TRUE(r.ok()) << r.error();
  for (size_t i = 0; i < items.size(); ++i) {
    ASSERT_TRUE((*r)[i].ok()) << format_address(items[i]);
    EXPECT_EQ((*r)[i].raw, raws[i]) << format_address(items[i]);
  }
  EXPECT_EQ(rig.fake.read_memory(rig.ep, Area::kDB, 1, 4, 2), (Bytes{0x00, 77}));
  EXPECT_EQ(rig.fake.read_memory(rig.ep, Area::kOutputs, 0, 1, 1), (Bytes{0x02}));
  EXPECT_EQ(rig.fake.read_memory(rig.ep, Area::kCounters, 0, 0, 2), (Bytes{0x00, 77}));
}

TEST(Session, reads_many_items_through_several_pdus) {
  FakeBehavior small;
  small.max_pdu = 240;
  SessionRig rig(small);
  std::vector<ItemAddress> items;
  for (uint16_t db = 1; db <= 16; ++db) {
    for (uint32_t k = 0; k < 3; ++k) {
      ItemAddress a;
      a.db = db;
      a.start = k * 100;
      a.type = DataType::kWord;
      items.push_back(a);
      const uint8_t v[] = {static_cast<uint8_t>(db), static_cast<uint8_t>(k)};
      rig.fake.write_memory(rig.ep, Area::kDB, db, a.start, v);
    }
  }
  Session s;
  ASSERT_TRUE(s.connect(rig.opt).ok());
  EXPECT_EQ(s.info().negotiated.pdu_size, 240);
  auto r = s.read(items);
  ASSERT_TRUE(r.ok()) << r.error();
  for (size_t i = 0; i < items.size(); ++i) EXPECT_EQ((*r)[i].raw, items[i].db * 256u + items[i].start / 100);
  EXPECT_GE(rig.fake.stats(rig.ep).requests, 4u);  // 48 vars at 19 per PDU, plus setup
}

TEST(Session, passes_the_plcs_item_errors_through) {
  SessionRig rig;
  Session s;
  ASSERT_TRUE(s.connect(rig.opt).ok());
  auto r = s.read(parse_all({"DB99.DBW0", "DB1.DBW2000", "MW0"}));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ((*r)[0].return_code, 0x0A);
  EXPECT_EQ((*r)[1].return_code, 0x05);
  EXPECT_TRUE((*r)[2].ok());
}

TEST(Session, says_clearly_when_nothing_answers) {
  FakeBehavior silent;
  silent.blackhole = FakeBehavior::Blackhole::kAcceptSilent;
  SessionRig rig(silent);
  rig.opt.connect_timeout_ms = 200;
  Session s;
  auto r = s.connect(rig.opt);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("S7 handshake"), std::string::npos) << r.error();
  rig.fake.kill(rig.ep);
  r = s.connect(rig.opt);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("refused"), std::string::npos) << r.error();
}

TEST(Session, fails_cleanly_on_a_malformed_reply) {
  FakeBehavior garbage;
  garbage.p_malformed = 1.0;
  SessionRig rig(garbage);
  Session s;
  ASSERT_TRUE(s.connect(rig.opt).ok());
  auto r = s.read(parse_all({"MW0"}));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("exceed"), std::string::npos) << r.error();
}

}  // namespace
}  // namespace rtplc::s7
