// libFuzzer target: every S7 decoder on arbitrary bytes (issue 4, item 7). The
// input is taken as a frame from a PLC; decoders must reject it or return spans
// inside it, never read past it (AddressSanitizer checks that).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "io/drivers/s7/planner.h"
#include "io/drivers/s7/protocol.h"
#include "io/drivers/s7/transfer.h"

using namespace rtplc::s7;

namespace {

bool inside(ByteSpan part, const uint8_t* data, size_t size) {
  return part.empty() || (part.data() >= data && part.data() + part.size() <= data + size);
}

const std::vector<ItemAddress>& plan_items() {
  static const std::vector<ItemAddress> items = [] {
    std::vector<ItemAddress> v;
    for (const char* t : {"DB1.DBW0", "DB1.DBX2.3", "DB1.DBD4:REAL", "MW10", "C3", "T1", "DB2.DBB7", "I0.0"}) {
      v.push_back(*parse_address(t));
    }
    return v;
  }();
  return items;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ByteSpan in(data, size);
  static const ReadPlan plan = *plan_reads(plan_items(), PlanLimits{});
  std::vector<DataItem> items;
  std::vector<uint8_t> codes;

  auto len = tpkt_frame_length(in);
  if (!len || *len == 0) return 0;
  const ByteSpan frame = in.first(*len);
  auto t = parse_frame(frame);
  if (!t) return 0;
  if (!inside(t->payload, data, size)) __builtin_trap();
  auto h = parse_s7(t->payload);
  if (!h) return 0;
  if (!inside(h->params, data, size) || !inside(h->data, data, size)) __builtin_trap();

  (void)parse_setup(*h);
  (void)parse_var_params(*h, kFuncRead);
  (void)parse_var_params(*h, kFuncWrite);
  const size_t count = h->params.size() >= 2 ? h->params[1] : 1;
  if (parse_read_reply(*h, count, items)) {
    for (const DataItem& d : items) {
      if (!inside(d.data, data, size)) __builtin_trap();
    }
  }
  (void)parse_data_items(h->data, count, false, items);
  (void)parse_write_reply(*h, count, codes);
  for (uint32_t r = 0; r < plan.requests.size(); ++r) {
    (void)apply_read_reply(plan, plan_items(), r, *h, items, [](uint32_t, const ItemResult&) {});
  }
  return 0;
}
