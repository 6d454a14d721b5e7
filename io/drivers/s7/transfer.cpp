// Job frames from plans and item values from replies (see transfer.h).
#include "io/drivers/s7/transfer.h"

#include <fmt/format.h>

#include <array>

namespace rtplc::s7 {

std::vector<Bytes> encode_read_frames(const ReadPlan& plan) {
  std::vector<Bytes> frames;
  frames.reserve(plan.requests.size());
  for (const PlannedRead& pr : plan.requests) {
    Bytes f;
    encode_read_request(f, 0, pr.vars);
    frames.push_back(std::move(f));
  }
  return frames;
}

Result<void> check_item_data(const DataItem& d, const ItemSlot& slot, const ItemAddress& a) {
  const size_t need = slot.offset + type_size(a.type);
  if (d.data.size() < need) {
    return make_error(fmt::format("reply carries {} bytes for {}, which needs {}", d.data.size(), format_address(a), need));
  }
  return {};
}

void encode_write_frame(Bytes& out, std::span<const ItemAddress> items, std::span<const uint64_t> raws,
                        std::span<const uint32_t> which) {
  std::array<VarSpec, kMaxItemsPerPdu> vars{};
  std::array<std::array<uint8_t, 4>, kMaxItemsPerPdu> buf{};
  std::array<ByteSpan, kMaxItemsPerPdu> values{};
  const size_t n = std::min(which.size(), kMaxItemsPerPdu);
  for (size_t i = 0; i < n; ++i) {
    const ItemAddress& a = items[which[i]];
    vars[i] = var_spec_for(a);
    const size_t size = type_size(a.type);
    encode_raw(a.type, raws[which[i]], std::span<uint8_t>(buf[i]).first(size));
    values[i] = ByteSpan(buf[i]).first(size);
  }
  encode_write_request(out, 0, std::span<const VarSpec>(vars).first(n), std::span<const ByteSpan>(values).first(n));
}

}  // namespace rtplc::s7
