// Request planning (issue 9, item 1: "contiguous addresses batched into as few
// requests as the protocol allows"): the read items of one slave grouped by
// table and poll period, sorted by address, and cut into blocks of contiguous
// (or overlapping) addresses no longer than the caps (125 registers, 2000 bits
// by default). One block is one read request.
#pragma once

#include <cstdint>
#include <vector>

#include "io/drivers/modbus/address.h"

namespace rtplc::modbus {

struct PlannedItem {
  Address address;
  int64_t period_ns = 0;
  uint32_t id = 0;  // the caller's index for the item
};

struct Block {
  Table table = Table::kHoldingRegister;
  uint16_t start = 0;
  uint16_t count = 0;  // registers or bits
  int64_t period_ns = 0;
  std::vector<uint32_t> items;  // indices into the planned items, by address
};

std::vector<Block> plan_blocks(const std::vector<PlannedItem>& items, uint16_t max_registers, uint16_t max_bits);

}  // namespace rtplc::modbus
