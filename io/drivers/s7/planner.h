// The request planner (spec: s7-client.md, "Limits"; issue 4, item 2): packs the
// items of one PLC into as few read PDUs as the negotiated PDU size allows.
//
// Items of one area/DB that overlap, touch or lie within `merge_gap` bytes of each
// other are read as one byte range (one request item); a range that would not fit in
// one reply is cut at item boundaries; the resulting request items are packed
// first-fit into PDUs so that both the request (12 + 12 N <= PDU, N <= 20) and the
// reply (14 + sum(4 + len + pad) <= PDU) fit. Writes are never merged (each value
// is written exactly as asked, a bit with a bit write), only packed.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/result.h"
#include "io/drivers/s7/address.h"
#include "io/drivers/s7/protocol.h"

namespace rtplc::s7 {

struct PlanLimits {
  size_t pdu = 240;                       // negotiated PDU size
  size_t max_items = kMaxItemsPerPdu;     // items per PDU the peer accepts
  uint32_t merge_gap = 8;                 // bytes read for nothing to save a request item
};

// Where one item's bytes are in the reply of its request.
struct ItemSlot {
  uint32_t request = 0;
  uint16_t var = 0;
  uint32_t offset = 0;  // bytes from the start of that var's data
};

struct PlannedRead {
  std::vector<VarSpec> vars;
  std::vector<uint32_t> items;  // indices of the items this request carries
  size_t request_bytes = 0;  // S7 PDU size of the request
  size_t reply_bytes = 0;    // S7 PDU size of the reply (upper bound)
};

struct ReadPlan {
  std::vector<PlannedRead> requests;
  std::vector<ItemSlot> slots;  // slots[i] for items[i]
};

// Plans reads of `items`. Fails only if the PDU is too small for any request.
Result<ReadPlan> plan_reads(std::span<const ItemAddress> items, const PlanLimits& limits);

struct PlannedWrite {
  std::vector<uint32_t> items;  // indices into the input, in order
  size_t request_bytes = 0;
};

// Packs writes of `items` (in order) into requests.
Result<std::vector<PlannedWrite>> plan_writes(std::span<const ItemAddress> items, const PlanLimits& limits);

// Bytes a write of `a` puts in the request (parameter item + data item + pad).
size_t write_item_bytes(const ItemAddress& a);

}  // namespace rtplc::s7
