// Request planning: merge, split and pack items into PDUs (spec: s7-client.md,
// "Limits"). See planner.h for the rules.
#include "io/drivers/s7/planner.h"

#include <fmt/format.h>

#include <algorithm>
#include <numeric>

namespace rtplc::s7 {
namespace {

constexpr size_t kMinPdu = 64;

bool is_element_area(Area a) { return a == Area::kCounters || a == Area::kTimers; }

// Units of an item inside its area: bytes, or elements for counters/timers.
uint32_t unit_bytes(Area a) { return is_element_area(a) ? 2 : 1; }
uint32_t item_units(const ItemAddress& a) {
  return is_element_area(a.area) ? 1 : static_cast<uint32_t>(type_size(a.type));
}

size_t max_items_per_request(const PlanLimits& l) {
  const size_t by_pdu = (l.pdu - kS7JobHeader - 2) / kReadItemSize;
  return std::max<size_t>(1, std::min(by_pdu, l.max_items));
}

struct Range {
  Area area;
  uint16_t db;
  uint32_t lo;  // units
  uint32_t hi;  // units, exclusive
};

}  // namespace

Result<ReadPlan> plan_reads(std::span<const ItemAddress> items, const PlanLimits& limits) {
  if (limits.pdu < kMinPdu) return make_error(fmt::format("PDU size {} is too small to plan requests", limits.pdu));
  const size_t max_var_bytes = max_read_bytes(limits.pdu);
  const size_t max_vars = max_items_per_request(limits);

  std::vector<uint32_t> order(items.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) {
    const ItemAddress& a = items[x];
    const ItemAddress& b = items[y];
    if (a.area != b.area) return a.area < b.area;
    if (a.db != b.db) return a.db < b.db;
    return a.start < b.start;
  });

  // Pass 1: ranges, each no larger than one reply can carry.
  std::vector<Range> ranges;
  std::vector<uint32_t> item_range(items.size());
  for (uint32_t idx : order) {
    const ItemAddress& a = items[idx];
    const uint32_t lo = a.start;
    const uint32_t hi = a.start + item_units(a);
    const uint32_t gap_units = limits.merge_gap / unit_bytes(a.area);
    bool merged = false;
    if (!ranges.empty()) {
      Range& r = ranges.back();
      const uint32_t new_hi = std::max(r.hi, hi);
      if (r.area == a.area && r.db == (a.area == Area::kDB ? a.db : 0) && lo <= r.hi + gap_units &&
          static_cast<size_t>(new_hi - r.lo) * unit_bytes(a.area) <= max_var_bytes) {
        r.hi = new_hi;
        merged = true;
      }
    }
    if (!merged) ranges.push_back(Range{a.area, a.area == Area::kDB ? a.db : uint16_t{0}, lo, hi});
    item_range[idx] = static_cast<uint32_t>(ranges.size() - 1);
  }

  // Pass 2: pack ranges first-fit into requests.
  ReadPlan plan;
  std::vector<std::pair<uint32_t, uint16_t>> range_pos(ranges.size());
  for (size_t ri = 0; ri < ranges.size(); ++ri) {
    const Range& r = ranges[ri];
    VarSpec v;
    v.area = r.area;
    v.db = r.db;
    if (is_element_area(r.area)) {
      v.ts = r.area == Area::kCounters ? TransportSize::kCounter : TransportSize::kTimer;
      v.address = r.lo;
    } else {
      v.ts = TransportSize::kByte;
      v.address = r.lo * 8;
    }
    v.count = static_cast<uint16_t>(r.hi - r.lo);
    const size_t need = reply_item_size(var_data_bytes(v));
    size_t target = plan.requests.size();
    for (size_t q = 0; q < plan.requests.size(); ++q) {
      const PlannedRead& pr = plan.requests[q];
      if (pr.vars.size() < max_vars && pr.reply_bytes + need <= limits.pdu) {
        target = q;
        break;
      }
    }
    if (target == plan.requests.size()) {
      plan.requests.push_back(PlannedRead{{}, {}, read_request_size(0), read_reply_base()});
    }
    PlannedRead& pr = plan.requests[target];
    range_pos[ri] = {static_cast<uint32_t>(target), static_cast<uint16_t>(pr.vars.size())};
    pr.vars.push_back(v);
    pr.request_bytes = read_request_size(pr.vars.size());
    pr.reply_bytes += need;
  }

  plan.slots.resize(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const Range& r = ranges[item_range[i]];
    plan.slots[i].request = range_pos[item_range[i]].first;
    plan.slots[i].var = range_pos[item_range[i]].second;
    plan.slots[i].offset = (items[i].start - r.lo) * unit_bytes(r.area);
    plan.requests[plan.slots[i].request].items.push_back(static_cast<uint32_t>(i));
  }
  return plan;
}

size_t write_item_bytes(const ItemAddress& a) {
  const size_t n = type_size(a.type);
  return kReadItemSize + 4 + n + (n & 1);
}

Result<std::vector<PlannedWrite>> plan_writes(std::span<const ItemAddress> items, const PlanLimits& limits) {
  if (limits.pdu < kMinPdu) return make_error(fmt::format("PDU size {} is too small to plan requests", limits.pdu));
  const size_t max_vars = max_items_per_request(limits);
  std::vector<PlannedWrite> out;
  for (uint32_t i = 0; i < items.size(); ++i) {
    const size_t need = write_item_bytes(items[i]);
    if (out.empty() || out.back().items.size() >= max_vars || out.back().request_bytes + need > limits.pdu ||
        read_reply_base() + out.back().items.size() + 1 > limits.pdu) {
      out.push_back(PlannedWrite{{}, kS7JobHeader + 2});
    }
    out.back().items.push_back(i);
    out.back().request_bytes += need;
  }
  return out;
}

}  // namespace rtplc::s7
