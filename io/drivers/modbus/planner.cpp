// Read request planning (see planner.h).
#include "io/drivers/modbus/planner.h"

#include <algorithm>
#include <numeric>
#include <tuple>

namespace rtplc::modbus {

std::vector<Block> plan_blocks(const std::vector<PlannedItem>& items, uint16_t max_registers, uint16_t max_bits) {
  std::vector<uint32_t> order(items.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const PlannedItem& x = items[a];
    const PlannedItem& y = items[b];
    return std::tuple(x.address.table, x.period_ns, x.address.address, a) <
           std::tuple(y.address.table, y.period_ns, y.address.address, b);
  });
  std::vector<Block> blocks;
  uint32_t end = 0;  // one past the last address of the open block
  for (uint32_t i : order) {
    const PlannedItem& it = items[i];
    const uint32_t start = it.address.address;
    const uint32_t stop = start + width(it.address);
    const uint32_t cap = is_bit_table(it.address.table) ? max_bits : max_registers;
    Block* open = blocks.empty() ? nullptr : &blocks.back();
    const bool joins = open && open->table == it.address.table && open->period_ns == it.period_ns &&
                       start <= end && std::max(end, stop) - open->start <= cap;
    if (!joins) {
      blocks.push_back(Block{it.address.table, static_cast<uint16_t>(start), 0, it.period_ns, {}});
      open = &blocks.back();
      end = start;
    }
    end = std::max(end, stop);
    open->count = static_cast<uint16_t>(end - open->start);
    open->items.push_back(i);
  }
  return blocks;
}

}  // namespace rtplc::modbus
