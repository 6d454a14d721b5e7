// libFuzzer target: the connection state machine fed an arbitrary byte stream as
// the PLC's side of the conversation (issue 4, item 7). The first byte chooses how
// the stream is cut into reads and whether a valid handshake precedes it, so the
// fuzzer reaches the ready state and exercises reply matching, reassembly and the
// reply decoding the engine does.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "io/drivers/s7/connection.h"
#include "io/drivers/s7/planner.h"
#include "io/drivers/s7/transfer.h"

using namespace rtplc::s7;

namespace {

Bytes handshake_prefix() {
  Bytes b = {0x03, 0x00, 0x00, 0x16, 0x11, 0xD0, 0x00, 0x01, 0x00, 0x01, 0x00,
             0xC0, 0x01, 0x0A, 0xC1, 0x02, 0x01, 0x00, 0xC2, 0x02, 0x01, 0x02};
  const size_t at = b.size();
  encode_ack_header(b, kRosctrAckData, 1, 8, 0, 0);  // the setup job is reference 1
  const uint8_t p[] = {kFuncSetup, 0, 0, 4, 0, 4, 0x00, 0xF0};
  b.insert(b.end(), std::begin(p), std::end(p));
  patch_tpkt_length(b, at);
  return b;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const std::vector<ItemAddress> items = [] {
    std::vector<ItemAddress> v;
    for (const char* t : {"DB1.DBW0", "DB1.DBX2.3", "MW10", "C3", "T1", "DB2.DBD8:REAL"}) v.push_back(*parse_address(t));
    return v;
  }();
  static const ReadPlan plan = *plan_reads(items, PlanLimits{});
  static const std::vector<Bytes> frames = encode_read_frames(plan);
  static const Bytes prefix = handshake_prefix();

  const uint8_t mode = data[0];
  Bytes stream;
  if (mode & 1) stream = prefix;
  stream.insert(stream.end(), data + 1, data + size);
  const size_t chunk = 1 + (mode >> 1);

  Connection c;
  c.open();
  std::vector<DataItem> scratch;
  std::vector<uint8_t> codes;
  Connection::Reply reply;
  size_t pos = 0;
  while (pos < stream.size() && c.state() != Connection::State::kFailed) {
    const size_t n = std::min(chunk, stream.size() - pos);
    c.consume_outbox(c.outbox().size());
    c.feed(ByteSpan(stream.data() + pos, n));
    pos += n;
    while (true) {
      const Connection::Event e = c.next_event(reply);
      if (e == Connection::Event::kNone || e == Connection::Event::kFailed) break;
      if (e == Connection::Event::kReply) {
        if (reply.cookie < plan.requests.size()) {
          (void)apply_read_reply(plan, items, reply.cookie, reply.header, scratch, [](uint32_t, const ItemResult&) {});
        } else {
          (void)parse_write_reply(reply.header, 1, codes);
        }
      }
      // Keep the pipeline full, like the engine does.
      for (uint32_t r = 0; c.can_send() && r < frames.size(); ++r) (void)c.send_job(r, frames[r]);
    }
    if (c.state() == Connection::State::kReady) {
      for (uint32_t r = 0; c.can_send() && r < frames.size(); ++r) (void)c.send_job(r, frames[r]);
      if (c.in_flight() > Connection::kMaxInFlight || c.in_flight() > c.max_in_flight()) __builtin_trap();
    }
  }
  return 0;
}
