// The connection state machine without sockets: handshake, AmQ, PDU-reference
// matching, reassembly and failure on malformed input (issue 4, items 1-3).
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "io/drivers/s7/connection.h"

namespace rtplc::s7 {
namespace {

Bytes connection_confirm() {
  Bytes cc = {0x03, 0x00, 0x00, 0x16, 0x11, 0xD0, 0x00, 0x01, 0x00, 0x01, 0x00,
              0xC0, 0x01, 0x0A, 0xC1, 0x02, 0x01, 0x00, 0xC2, 0x02, 0x01, 0x02};
  return cc;
}

Bytes setup_ack(uint16_t ref, uint16_t amq, uint16_t pdu) {
  Bytes out;
  encode_ack_header(out, kRosctrAckData, ref, 8, 0, 0);
  const uint8_t p[] = {kFuncSetup, 0, static_cast<uint8_t>(amq >> 8), static_cast<uint8_t>(amq),
                       static_cast<uint8_t>(amq >> 8), static_cast<uint8_t>(amq), static_cast<uint8_t>(pdu >> 8),
                       static_cast<uint8_t>(pdu)};
  out.insert(out.end(), std::begin(p), std::end(p));
  patch_tpkt_length(out, 0);
  return out;
}

Bytes read_reply(uint16_t ref, uint8_t value) {
  const uint8_t d[] = {value};
  const DataItem item{kItemOk, DataSize::kByte, d};
  Bytes out;
  encode_read_reply(out, ref, std::span<const DataItem>(&item, 1));
  return out;
}

uint16_t ref_in_outbox(const Connection& c, size_t frame_offset = 0) {
  ByteSpan o = c.outbox();
  return static_cast<uint16_t>(o[frame_offset + kFramePduRefOffset] << 8 | o[frame_offset + kFramePduRefOffset + 1]);
}

// Drives a machine to kReady with the given grant.
void handshake(Connection& c, uint16_t amq, uint16_t pdu) {
  c.open();
  c.consume_outbox(c.outbox().size());
  Connection::Reply r;
  c.feed(connection_confirm());
  ASSERT_EQ(c.next_event(r), Connection::Event::kNone);
  ASSERT_EQ(c.state(), Connection::State::kAwaitSetup);
  const uint16_t ref = ref_in_outbox(c);
  c.consume_outbox(c.outbox().size());
  c.feed(setup_ack(ref, amq, pdu));
  ASSERT_EQ(c.next_event(r), Connection::Event::kReady);
}

const VarSpec kVar{TransportSize::kByte, 1, 1, Area::kDB, 0};

TEST(Connection, sends_connection_request_then_setup_and_becomes_ready) {
  ConnectionConfig cfg;
  cfg.local_tsap = 0x1000;
  cfg.remote_tsap = 0x2000;
  cfg.setup = SetupParams{8, 8, 960};
  Connection c(cfg);
  c.open();
  Bytes cr(c.outbox().begin(), c.outbox().end());
  Bytes want;
  encode_connection_request(want, 0x1000, 0x2000);
  EXPECT_EQ(cr, want);
  handshake(c, 3, 240);
  EXPECT_EQ(c.state(), Connection::State::kReady);
  EXPECT_EQ(c.negotiated().pdu_size, 240);
  EXPECT_EQ(c.max_in_flight(), 3u);
}

TEST(Connection, never_exceeds_the_negotiated_amq) {
  Connection c;
  handshake(c, 2, 240);
  EXPECT_TRUE(c.send_read(1, std::span<const VarSpec>(&kVar, 1)).ok());
  EXPECT_TRUE(c.send_read(2, std::span<const VarSpec>(&kVar, 1)).ok());
  EXPECT_FALSE(c.can_send());
  EXPECT_FALSE(c.send_read(3, std::span<const VarSpec>(&kVar, 1)).ok());
}

TEST(Connection, matches_replies_by_pdu_reference_in_any_order) {
  Connection c;
  handshake(c, 4, 240);
  const uint16_t r1 = *c.send_read(11, std::span<const VarSpec>(&kVar, 1));
  const uint16_t r2 = *c.send_read(22, std::span<const VarSpec>(&kVar, 1));
  ASSERT_NE(r1, r2);
  Bytes both = read_reply(r2, 2);
  const Bytes first = read_reply(r1, 1);
  both.insert(both.end(), first.begin(), first.end());
  c.feed(both);
  Connection::Reply r;
  ASSERT_EQ(c.next_event(r), Connection::Event::kReply);
  EXPECT_EQ(r.cookie, 22u);
  ASSERT_EQ(c.next_event(r), Connection::Event::kReply);
  EXPECT_EQ(r.cookie, 11u);
  EXPECT_EQ(c.in_flight(), 0u);
}

TEST(Connection, drops_and_counts_replies_that_match_no_job) {
  Connection c;
  handshake(c, 4, 240);
  const uint16_t ref = *c.send_read(5, std::span<const VarSpec>(&kVar, 1));
  c.feed(read_reply(static_cast<uint16_t>(ref + 100), 9));
  Connection::Reply r;
  EXPECT_EQ(c.next_event(r), Connection::Event::kNone);
  EXPECT_EQ(c.dropped_replies(), 1u);
  EXPECT_EQ(c.state(), Connection::State::kReady);
  // A reply to a job given up on is dropped too.
  c.forget(ref);
  c.feed(read_reply(ref, 9));
  EXPECT_EQ(c.next_event(r), Connection::Event::kNone);
  EXPECT_EQ(c.dropped_replies(), 2u);
}

TEST(Connection, reassembles_a_reply_fed_one_byte_at_a_time) {
  Connection c;
  handshake(c, 1, 240);
  const uint16_t ref = *c.send_read(7, std::span<const VarSpec>(&kVar, 1));
  const Bytes reply = read_reply(ref, 0x5A);
  Connection::Reply r;
  for (size_t i = 0; i + 1 < reply.size(); ++i) {
    c.feed(ByteSpan(&reply[i], 1));
    ASSERT_EQ(c.next_event(r), Connection::Event::kNone);
  }
  c.feed(ByteSpan(&reply.back(), 1));
  ASSERT_EQ(c.next_event(r), Connection::Event::kReply);
  std::vector<DataItem> items;
  ASSERT_TRUE(parse_read_reply(r.header, 1, items).ok());
  EXPECT_EQ(items[0].data[0], 0x5A);
}

TEST(Connection, joins_cotp_data_units_without_end_of_transmission) {
  Connection c;
  handshake(c, 1, 240);
  const uint16_t ref = *c.send_read(7, std::span<const VarSpec>(&kVar, 1));
  const Bytes whole = read_reply(ref, 0x33);
  const ByteSpan payload = ByteSpan(whole).subspan(kTpktHeader + kCotpDtHeader);
  auto unit = [](ByteSpan part, bool last) {
    Bytes f(7 + part.size());
    f[0] = 0x03;
    f[4] = 0x02;
    f[5] = 0xF0;
    f[6] = last ? 0x80 : 0x00;
    std::copy(part.begin(), part.end(), f.begin() + 7);
    patch_tpkt_length(f, 0);
    return f;
  };
  c.feed(unit(payload.first(6), false));
  c.feed(unit(payload.subspan(6), true));
  Connection::Reply r;
  ASSERT_EQ(c.next_event(r), Connection::Event::kReply);
  EXPECT_EQ(r.cookie, 7u);
}

TEST(Connection, fails_with_a_hint_when_the_plc_refuses_the_tsap) {
  Connection c;
  c.open();
  c.feed(Bytes{0x03, 0x00, 0x00, 0x0B, 0x06, 0x80, 0x00, 0x01, 0x00, 0x02, 0x81});
  Connection::Reply r;
  ASSERT_EQ(c.next_event(r), Connection::Event::kFailed);
  EXPECT_NE(c.error().find("rack/slot"), std::string::npos) << c.error();
}

TEST(Connection, fails_on_a_malformed_frame_and_stays_failed) {
  Connection c;
  handshake(c, 1, 240);
  c.feed(Bytes{0x07, 0x00, 0x00, 0x10});
  Connection::Reply r;
  ASSERT_EQ(c.next_event(r), Connection::Event::kFailed);
  EXPECT_EQ(c.state(), Connection::State::kFailed);
  EXPECT_FALSE(c.send_read(1, std::span<const VarSpec>(&kVar, 1)).ok());
  c.feed(read_reply(1, 1));
  EXPECT_EQ(c.next_event(r), Connection::Event::kNone);
}

TEST(Connection, refuses_a_setup_answer_with_a_tiny_pdu) {
  Connection c;
  c.open();
  c.consume_outbox(c.outbox().size());
  c.feed(connection_confirm());
  Connection::Reply r;
  ASSERT_EQ(c.next_event(r), Connection::Event::kNone);
  const uint16_t ref = ref_in_outbox(c);
  c.feed(setup_ack(ref, 1, 16));
  ASSERT_EQ(c.next_event(r), Connection::Event::kFailed);
  EXPECT_NE(c.error().find("too small"), std::string::npos) << c.error();
}

}  // namespace
}  // namespace rtplc::s7
