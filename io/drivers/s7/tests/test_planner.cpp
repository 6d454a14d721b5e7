// The request planner (issue 4, item 2): merging, splitting and packing under the
// request and reply limits of the negotiated PDU.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "io/drivers/s7/planner.h"

namespace rtplc::s7 {
namespace {

ItemAddress db_word(uint16_t db, uint32_t offset) {
  ItemAddress a;
  a.area = Area::kDB;
  a.db = db;
  a.start = offset;
  a.type = DataType::kWord;
  return a;
}

// Every request fits the PDU both ways, and every item lies inside its var.
void expect_consistent(const ReadPlan& plan, const std::vector<ItemAddress>& items, size_t pdu) {
  ASSERT_EQ(plan.slots.size(), items.size());
  size_t carried = 0;
  for (const PlannedRead& r : plan.requests) {
    EXPECT_LE(read_request_size(r.vars.size()), pdu);
    EXPECT_LE(r.vars.size(), kMaxItemsPerPdu);
    size_t reply = read_reply_base();
    for (const VarSpec& v : r.vars) reply += reply_item_size(var_data_bytes(v));
    EXPECT_LE(reply, pdu);
    carried += r.items.size();
  }
  EXPECT_EQ(carried, items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const ItemSlot& s = plan.slots[i];
    ASSERT_LT(s.request, plan.requests.size());
    ASSERT_LT(s.var, plan.requests[s.request].vars.size());
    const VarSpec& v = plan.requests[s.request].vars[s.var];
    EXPECT_EQ(v.area, items[i].area);
    EXPECT_LE(s.offset + type_size(items[i].type), var_data_bytes(v)) << "item " << i;
    const bool elements = v.area == Area::kCounters || v.area == Area::kTimers;
    const uint32_t var_start = elements ? v.address : v.address / 8;
    EXPECT_EQ(var_start + s.offset / (elements ? 2 : 1), items[i].start) << "item " << i;
  }
}

TEST(Planner, merges_ten_adjacent_words_into_one_request_item) {
  std::vector<ItemAddress> items;
  for (uint32_t i = 0; i < 10; ++i) items.push_back(db_word(1, i * 2));
  auto plan = plan_reads(items, PlanLimits{});
  ASSERT_TRUE(plan.ok()) << plan.error();
  ASSERT_EQ(plan->requests.size(), 1u);
  ASSERT_EQ(plan->requests[0].vars.size(), 1u);
  EXPECT_EQ(plan->requests[0].vars[0].count, 20);
  expect_consistent(*plan, items, 240);
}

TEST(Planner, merges_within_the_gap_and_not_beyond) {
  std::vector<ItemAddress> items = {db_word(1, 0), db_word(1, 20)};
  PlanLimits lim;
  lim.merge_gap = 8;
  EXPECT_EQ(plan_reads(items, lim)->requests[0].vars.size(), 2u);
  lim.merge_gap = 32;
  auto merged = plan_reads(items, lim);
  ASSERT_EQ(merged->requests[0].vars.size(), 1u);
  EXPECT_EQ(merged->requests[0].vars[0].count, 22);
  expect_consistent(*merged, items, 240);
}

TEST(Planner, merges_overlapping_items_and_bits_of_one_byte) {
  std::vector<ItemAddress> items = {db_word(1, 4), db_word(1, 5)};
  ItemAddress bit;
  bit.area = Area::kDB;
  bit.db = 1;
  bit.start = 6;
  bit.bit = 3;
  bit.type = DataType::kBool;
  items.push_back(bit);
  auto plan = plan_reads(items, PlanLimits{});
  ASSERT_EQ(plan->requests[0].vars.size(), 1u);
  EXPECT_EQ(plan->requests[0].vars[0].count, 3);
  expect_consistent(*plan, items, 240);
}

TEST(Planner, keeps_areas_and_dbs_apart) {
  std::vector<ItemAddress> items = {db_word(1, 0), db_word(2, 0)};
  ItemAddress m;
  m.area = Area::kFlags;
  m.type = DataType::kWord;
  items.push_back(m);
  ItemAddress c;
  c.area = Area::kCounters;
  c.type = DataType::kCounter;
  items.push_back(c);
  auto plan = plan_reads(items, PlanLimits{});
  ASSERT_EQ(plan->requests.size(), 1u);
  EXPECT_EQ(plan->requests[0].vars.size(), 4u);
  expect_consistent(*plan, items, 240);
}

TEST(Planner, splits_a_range_larger_than_one_reply) {
  std::vector<ItemAddress> items;
  for (uint32_t i = 0; i < 300; ++i) items.push_back(db_word(1, i * 2));  // 600 bytes
  auto plan = plan_reads(items, PlanLimits{});
  ASSERT_TRUE(plan.ok());
  // 222 bytes per reply at PDU 240 -> three requests.
  EXPECT_EQ(plan->requests.size(), 3u);
  for (const auto& r : plan->requests) {
    for (const auto& v : r.vars) EXPECT_LE(var_data_bytes(v), max_read_bytes(240));
  }
  expect_consistent(*plan, items, 240);
  // A bigger PDU needs fewer requests.
  PlanLimits big;
  big.pdu = 960;
  EXPECT_EQ(plan_reads(items, big)->requests.size(), 1u);
}

TEST(Planner, packs_scattered_items_at_nineteen_per_request) {
  std::vector<ItemAddress> items;
  for (uint16_t db = 1; db <= 50; ++db) items.push_back(db_word(db, 0));
  auto plan = plan_reads(items, PlanLimits{});
  ASSERT_TRUE(plan.ok());
  EXPECT_EQ(plan->requests.size(), 3u);  // 19 + 19 + 12
  EXPECT_EQ(plan->requests[0].vars.size(), 19u);
  expect_consistent(*plan, items, 240);
}

TEST(Planner, honours_the_item_limit_of_the_peer) {
  std::vector<ItemAddress> items;
  for (uint16_t db = 1; db <= 30; ++db) items.push_back(db_word(db, 0));
  PlanLimits lim;
  lim.pdu = 960;
  auto plan = plan_reads(items, lim);
  EXPECT_EQ(plan->requests.size(), 2u);  // 20 + 10: snap7 and CPUs refuse more than 20
  expect_consistent(*plan, items, 960);
}

TEST(Planner, keeps_random_plans_within_both_limits) {
  std::mt19937 rng(42u);  // 32-bit results: fits every field below
  for (size_t pdu : {240u, 480u, 960u}) {
    for (int round = 0; round < 20; ++round) {
      std::vector<ItemAddress> items;
      const int n = 1 + static_cast<int>(rng() % 200);
      for (int i = 0; i < n; ++i) {
        ItemAddress a;
        const uint32_t kind = static_cast<uint32_t>(rng() % 6);
        const Area areas[] = {Area::kDB, Area::kDB, Area::kFlags, Area::kInputs, Area::kCounters, Area::kTimers};
        a.area = areas[kind];
        a.db = a.area == Area::kDB ? static_cast<uint16_t>(1 + rng() % 4) : 0;
        a.start = static_cast<uint32_t>(rng() % 2000);
        const DataType types[] = {DataType::kBool, DataType::kByte, DataType::kInt, DataType::kReal};
        a.type = a.area == Area::kCounters ? DataType::kCounter
                 : a.area == Area::kTimers ? DataType::kTimer
                                           : types[rng() % 4];
        a.bit = static_cast<uint8_t>(rng() % 8);
        items.push_back(a);
      }
      PlanLimits lim;
      lim.pdu = pdu;
      lim.merge_gap = static_cast<uint32_t>(rng() % 40);
      auto plan = plan_reads(items, lim);
      ASSERT_TRUE(plan.ok());
      expect_consistent(*plan, items, pdu);
    }
  }
}

TEST(Planner, packs_writes_within_the_pdu) {
  std::vector<ItemAddress> items;
  for (uint32_t i = 0; i < 40; ++i) items.push_back(db_word(1, i * 2));
  auto groups = plan_writes(items, PlanLimits{});
  ASSERT_TRUE(groups.ok());
  size_t total = 0;
  for (const auto& g : *groups) {
    EXPECT_LE(g.request_bytes, 240u);
    EXPECT_LE(g.items.size(), kMaxItemsPerPdu);
    total += g.items.size();
  }
  EXPECT_EQ(total, 40u);
  // 12 + 18 bytes per word write: 12 of them fit in 240.
  EXPECT_EQ((*groups)[0].items.size(), 12u);
}

TEST(Planner, refuses_a_pdu_too_small_to_plan) {
  std::vector<ItemAddress> items = {db_word(1, 0)};
  PlanLimits lim;
  lim.pdu = 20;
  EXPECT_FALSE(plan_reads(items, lim).ok());
}

}  // namespace
}  // namespace rtplc::s7
