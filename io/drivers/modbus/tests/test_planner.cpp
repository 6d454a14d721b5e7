// Read request planning (planner.h): contiguous items batched up to the caps.
#include <gtest/gtest.h>

#include "io/drivers/modbus/planner.h"

namespace rtplc::modbus {
namespace {

PlannedItem item(const char* spec, int64_t period = 100, uint32_t id = 0) {
  return PlannedItem{*parse_address(spec), period, id};
}

TEST(ModbusPlanner, batches_contiguous_registers_into_one_request) {
  const auto blocks = plan_blocks({item("hr:2"), item("hr:0"), item("hr:1"), item("hr:3:f32")}, 125, 2000);
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].start, 0);
  EXPECT_EQ(blocks[0].count, 5);
  EXPECT_EQ(blocks[0].items, (std::vector<uint32_t>{1, 2, 0, 3}));
}

TEST(ModbusPlanner, splits_at_gaps_tables_periods_and_the_cap) {
  EXPECT_EQ(plan_blocks({item("hr:0"), item("hr:2")}, 125, 2000).size(), 2u);
  EXPECT_EQ(plan_blocks({item("hr:0"), item("ir:1")}, 125, 2000).size(), 2u);
  EXPECT_EQ(plan_blocks({item("hr:0", 100), item("hr:1", 50)}, 125, 2000).size(), 2u);
  std::vector<PlannedItem> many;
  for (int i = 0; i < 300; ++i) many.push_back(item(("hr:" + std::to_string(i)).c_str()));
  const auto blocks = plan_blocks(many, 125, 2000);
  ASSERT_EQ(blocks.size(), 3u);
  EXPECT_EQ(blocks[0].count, 125);
  EXPECT_EQ(blocks[2].count, 50);
  std::vector<PlannedItem> bits;
  for (int i = 0; i < 2500; ++i) bits.push_back(item(("coil:" + std::to_string(i)).c_str()));
  EXPECT_EQ(plan_blocks(bits, 125, 2000).size(), 2u);
  EXPECT_EQ(plan_blocks(many, 10, 2000).size(), 30u);
}

TEST(ModbusPlanner, a_pair_never_straddles_two_requests) {
  const auto blocks = plan_blocks({item("hr:0"), item("hr:1:f32")}, 2, 2000);
  ASSERT_EQ(blocks.size(), 2u);
  EXPECT_EQ(blocks[1].start, 1);
  EXPECT_EQ(blocks[1].count, 2);
}

}  // namespace
}  // namespace rtplc::modbus
