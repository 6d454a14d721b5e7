// Carrying out a plan (spec: s7-client.md, "Read var"/"Write var"): the job frames
// of a read plan, the item values out of a read reply, and the frames and results of
// a write. Shared by the engine and the command-line session so both read replies
// the same way.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/result.h"
#include "io/drivers/s7/address.h"
#include "io/drivers/s7/planner.h"
#include "io/drivers/s7/protocol.h"

namespace rtplc::s7 {

// What one item of a reply holds.
struct ItemResult {
  uint8_t return_code = 0;  // kItemOk or the PLC's item error
  uint64_t raw = 0;         // valid when return_code == kItemOk
  bool ok() const { return return_code == kItemOk; }
};

// Every request of `plan` as a whole job frame with PDU reference 0
// (Connection::send_job patches the reference), so a poll costs no encoding.
std::vector<Bytes> encode_read_frames(const ReadPlan& plan);

// Decodes the reply `h` to request `request` of `plan` and calls
// sink(item_index, const ItemResult&) for every item of that request. A header
// error is returned as an error (every item of the request failed); a reply whose
// data cannot hold the items it claims to carry is an error too (malformed).
template <typename Sink>
Result<void> apply_read_reply(const ReadPlan& plan, std::span<const ItemAddress> items, uint32_t request,
                              const S7Header& h, std::vector<DataItem>& scratch, Sink&& sink);

// Encodes one write request for items[idx] := raws[idx] for idx in `which`.
void encode_write_frame(Bytes& out, std::span<const ItemAddress> items, std::span<const uint64_t> raws,
                        std::span<const uint32_t> which);

// ---------------------------------------------------------------------------------

Result<void> check_item_data(const DataItem& d, const ItemSlot& slot, const ItemAddress& a);

template <typename Sink>
Result<void> apply_read_reply(const ReadPlan& plan, std::span<const ItemAddress> items, uint32_t request,
                              const S7Header& h, std::vector<DataItem>& scratch, Sink&& sink) {
  const PlannedRead& pr = plan.requests[request];
  if (auto ok = parse_read_reply(h, pr.vars.size(), scratch); !ok) return ok;
  for (uint32_t idx : pr.items) {
    const ItemSlot& slot = plan.slots[idx];
    const DataItem& d = scratch[slot.var];
    ItemResult r;
    r.return_code = d.return_code;
    if (d.return_code == kItemOk) {
      if (auto ok = check_item_data(d, slot, items[idx]); !ok) return ok;
      r.raw = decode_raw(items[idx].type, items[idx].bit, d.data.subspan(slot.offset));
    }
    sink(idx, static_cast<const ItemResult&>(r));
  }
  return {};
}

}  // namespace rtplc::s7
