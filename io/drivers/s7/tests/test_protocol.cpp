// Byte-for-byte tests of the S7 encoders and decoders against the layouts of
// spec s7-client.md ("Protocol"), including the seed's VB100 frame, and the
// decoders' behaviour on truncated and lying input.
#include <gtest/gtest.h>

#include <vector>

#include "io/drivers/s7/protocol.h"

namespace rtplc::s7 {
namespace {

// The seed's figure 1: read 1 byte of DB1 at byte 100, PDU reference 0x038E.
const Bytes kSeedVb100 = {0x03, 0x00, 0x00, 0x1f, 0x02, 0xf0, 0x80, 0x32, 0x01, 0x00, 0x00, 0x03, 0x8e, 0x00, 0x0e, 0x00,
                          0x00, 0x04, 0x01, 0x12, 0x0a, 0x10, 0x02, 0x00, 0x01, 0x00, 0x01, 0x84, 0x00, 0x03, 0x20};

// A reply to it carrying 0x2A.
const Bytes kSeedReply = {0x03, 0x00, 0x00, 0x1A, 0x02, 0xF0, 0x80, 0x32, 0x03, 0x00, 0x00, 0x03, 0x8E,
                          0x00, 0x02, 0x00, 0x05, 0x00, 0x00, 0x04, 0x01, 0xFF, 0x04, 0x00, 0x08, 0x2A};

S7Header header_of(const Bytes& frame) {
  auto t = parse_frame(frame);
  EXPECT_TRUE(t.ok()) << t.error();
  auto h = parse_s7(t->payload);
  EXPECT_TRUE(h.ok()) << h.error();
  return *h;
}

TEST(Protocol, encodes_connection_request_with_rack_slot_tsap) {
  Bytes out;
  encode_connection_request(out, 0x0100, remote_tsap(ConnectionType::kPG, 0, 2));
  const Bytes want = {0x03, 0x00, 0x00, 0x16, 0x11, 0xE0, 0x00, 0x00, 0x00, 0x01, 0x00,
                      0xC0, 0x01, 0x0A, 0xC1, 0x02, 0x01, 0x00, 0xC2, 0x02, 0x01, 0x02};
  EXPECT_EQ(out, want);
}

TEST(Protocol, computes_remote_tsap_from_type_rack_and_slot) {
  EXPECT_EQ(remote_tsap(ConnectionType::kPG, 0, 2), 0x0102);
  EXPECT_EQ(remote_tsap(ConnectionType::kOP, 0, 1), 0x0201);
  EXPECT_EQ(remote_tsap(ConnectionType::kBasic, 1, 3), 0x0323);
}

TEST(Protocol, encodes_setup_communication_request) {
  Bytes out;
  encode_setup_request(out, 0, SetupParams{1, 1, 480});
  const Bytes want = {0x03, 0x00, 0x00, 0x19, 0x02, 0xF0, 0x80, 0x32, 0x01, 0x00, 0x00, 0x00, 0x00,
                      0x00, 0x08, 0x00, 0x00, 0xF0, 0x00, 0x00, 0x01, 0x00, 0x01, 0x01, 0xE0};
  EXPECT_EQ(out, want);
}

TEST(Protocol, encodes_the_seeds_vb100_read_frame) {
  Bytes out;
  const VarSpec v{TransportSize::kByte, 1, 1, Area::kDB, 100 * 8};
  encode_read_request(out, 0x038E, std::span<const VarSpec>(&v, 1));
  EXPECT_EQ(out, kSeedVb100);
}

TEST(Protocol, decodes_the_seeds_vb100_read_frame) {
  const S7Header h = header_of(kSeedVb100);
  EXPECT_EQ(h.rosctr, kRosctrJob);
  EXPECT_EQ(h.pdu_ref, 0x038E);
  auto vars = parse_var_params(h, kFuncRead);
  ASSERT_TRUE(vars.ok()) << vars.error();
  ASSERT_EQ(vars->size(), 1u);
  EXPECT_EQ((*vars)[0].ts, TransportSize::kByte);
  EXPECT_EQ((*vars)[0].count, 1);
  EXPECT_EQ((*vars)[0].db, 1);
  EXPECT_EQ((*vars)[0].area, Area::kDB);
  EXPECT_EQ((*vars)[0].address, 800u);
}

TEST(Protocol, decodes_a_read_reply_with_bit_length) {
  std::vector<DataItem> items;
  auto ok = parse_read_reply(header_of(kSeedReply), 1, items);
  ASSERT_TRUE(ok.ok()) << ok.error();
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].return_code, kItemOk);
  EXPECT_EQ(items[0].size, DataSize::kByte);
  ASSERT_EQ(items[0].data.size(), 1u);
  EXPECT_EQ(items[0].data[0], 0x2A);
}

TEST(Protocol, round_trips_a_read_reply_with_fill_bytes_and_item_errors) {
  const Bytes one = {0x11};
  const Bytes four = {0x41, 0x20, 0x00, 0x00};
  const DataItem in[] = {{kItemOk, DataSize::kByte, one}, {0x0A, DataSize::kNull, {}}, {kItemOk, DataSize::kReal, four}};
  Bytes frame;
  encode_read_reply(frame, 7, in);
  // Item 1 is odd-length and not last: a fill byte follows it.
  const Bytes want_data = {0xFF, 0x04, 0x00, 0x08, 0x11, 0x00, 0x0A, 0x00, 0x00, 0x00,
                           0xFF, 0x07, 0x00, 0x04, 0x41, 0x20, 0x00, 0x00};
  const S7Header h = header_of(frame);
  EXPECT_EQ(Bytes(h.data.begin(), h.data.end()), want_data);
  std::vector<DataItem> out;
  ASSERT_TRUE(parse_read_reply(h, 3, out).ok());
  EXPECT_EQ(out[0].data[0], 0x11);
  EXPECT_EQ(out[1].return_code, 0x0A);
  EXPECT_EQ(out[2].data.size(), 4u);
  EXPECT_EQ(out[2].data[1], 0x20);
}

TEST(Protocol, reads_no_data_from_a_refused_item_whatever_its_length_says) {
  // snap7 answers a missing DB with 0A 00 00 04 and no data bytes after it.
  const Bytes data = {0x0A, 0x00, 0x00, 0x04, 0xFF, 0x04, 0x00, 0x10, 0x12, 0x34};
  std::vector<DataItem> items;
  ASSERT_TRUE(parse_data_items(data, 2, true, items).ok());
  EXPECT_EQ(items[0].return_code, 0x0A);
  EXPECT_TRUE(items[0].data.empty());
  ASSERT_EQ(items[1].data.size(), 2u);
  EXPECT_EQ(items[1].data[0], 0x12);
}

TEST(Protocol, encodes_word_and_bit_writes) {
  const VarSpec vars[] = {{TransportSize::kByte, 2, 1, Area::kDB, 4 * 8}, {TransportSize::kBit, 1, 1, Area::kDB, 3}};
  const Bytes w = {0x12, 0x34};
  const Bytes b = {0x01};
  const ByteSpan values[] = {w, b};
  Bytes out;
  encode_write_request(out, 2, vars, values);
  const Bytes want = {0x03, 0x00, 0x00, 0x36, 0x02, 0xF0, 0x80,                          // TPKT, COTP DT
                      0x32, 0x01, 0x00, 0x00, 0x00, 0x02, 0x00, 0x1A, 0x00, 0x0B,        // header
                      0x05, 0x02,                                                        // write, 2 items
                      0x12, 0x0A, 0x10, 0x02, 0x00, 0x02, 0x00, 0x01, 0x84, 0x00, 0x00, 0x20,
                      0x12, 0x0A, 0x10, 0x01, 0x00, 0x01, 0x00, 0x01, 0x84, 0x00, 0x00, 0x03,
                      0x00, 0x04, 0x00, 0x10, 0x12, 0x34,                                // word, 16 bits
                      0x00, 0x03, 0x00, 0x01, 0x01};                                     // bit
  EXPECT_EQ(out, want);
  const S7Header h = header_of(out);
  std::vector<DataItem> data;
  ASSERT_TRUE(parse_data_items(h.data, 2, false, data).ok());
  EXPECT_EQ(data[1].data.size(), 1u);
}

TEST(Protocol, decodes_write_reply_return_codes) {
  const uint8_t codes_in[] = {kItemOk, 0x05};
  Bytes frame;
  encode_write_reply(frame, 9, codes_in);
  std::vector<uint8_t> codes;
  ASSERT_TRUE(parse_write_reply(header_of(frame), 2, codes).ok());
  EXPECT_EQ(codes, (std::vector<uint8_t>{0xFF, 0x05}));
}

TEST(Protocol, maps_header_errors_to_clear_messages) {
  Bytes frame;
  encode_error_reply(frame, 3, 0x8104);
  std::vector<DataItem> items;
  auto r = parse_read_reply(header_of(frame), 1, items);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("PUT/GET"), std::string::npos) << r.error();
  EXPECT_NE(header_error_message(0x8500).find("PDU"), std::string::npos);
  EXPECT_NE(header_error_message(0x8304).find("write"), std::string::npos);
  EXPECT_NE(header_error_message(0x8702).find("0x8702"), std::string::npos);
  EXPECT_NE(header_error_message(0x8599).find("class 0x85"), std::string::npos);
}

TEST(Protocol, maps_item_return_codes_to_clear_messages) {
  EXPECT_NE(item_error_message(0x0A).find("does not exist"), std::string::npos);
  EXPECT_NE(item_error_message(0x05).find("out of range"), std::string::npos);
  EXPECT_NE(item_error_message(0x03).find("not allowed"), std::string::npos);
  EXPECT_NE(item_error_message(0x06).find("not supported"), std::string::npos);
  EXPECT_NE(item_error_message(0x07).find("inconsistent"), std::string::npos);
  EXPECT_NE(item_error_message(0x01).find("hardware"), std::string::npos);
}

TEST(Protocol, parses_connection_confirm_and_disconnect) {
  const Bytes cc = {0x03, 0x00, 0x00, 0x16, 0x11, 0xD0, 0x00, 0x01, 0x44, 0x31, 0x00,
                    0xC0, 0x01, 0x0A, 0xC1, 0x02, 0x01, 0x00, 0xC2, 0x02, 0x01, 0x02};
  auto t = parse_frame(cc);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(t->type, CotpType::kConnectionConfirm);
  EXPECT_EQ(t->tpdu_size, 1024);
  EXPECT_EQ(t->called_tsap, 0x0102);
  const Bytes dr = {0x03, 0x00, 0x00, 0x0B, 0x06, 0x80, 0x00, 0x01, 0x00, 0x02, 0x80};
  auto d = parse_frame(dr);
  ASSERT_TRUE(d.ok()) << d.error();
  EXPECT_EQ(d->type, CotpType::kDisconnectRequest);
  EXPECT_EQ(d->reason, 0x80);
}

TEST(Protocol, rejects_every_truncation_of_a_reply) {
  for (size_t n = 0; n < kSeedReply.size(); ++n) {
    const ByteSpan part(kSeedReply.data(), n);
    auto len = tpkt_frame_length(part);
    ASSERT_TRUE(len.ok());
    EXPECT_EQ(*len, 0u) << "prefix of " << n << " bytes taken as a whole frame";
    EXPECT_FALSE(parse_frame(part).ok());
  }
}

TEST(Protocol, rejects_lying_length_fields) {
  // S7 data length says 50 bytes.
  Bytes lie = kSeedReply;
  lie[16] = 50;
  auto t = parse_frame(lie);
  ASSERT_TRUE(t.ok());
  EXPECT_FALSE(parse_s7(t->payload).ok());
  // Item length says 800 bits (100 bytes) but one byte follows.
  Bytes item = kSeedReply;
  item[23] = 0x03;
  item[24] = 0x20;
  std::vector<DataItem> items;
  EXPECT_FALSE(parse_read_reply(header_of(item), 1, items).ok());
  // Reply claims two items when one was asked for.
  Bytes count = kSeedReply;
  count[20] = 2;
  EXPECT_FALSE(parse_read_reply(header_of(count), 1, items).ok());
  // COTP length indicator past the frame.
  Bytes li = kSeedReply;
  li[4] = 0x40;
  EXPECT_FALSE(parse_frame(li).ok());
  // TPKT lengths that cannot be.
  EXPECT_FALSE(tpkt_frame_length(Bytes{0x03, 0x00, 0x00, 0x03}).ok());
  EXPECT_FALSE(tpkt_frame_length(Bytes{0x03, 0x00, 0xFF, 0xFF}).ok());
  EXPECT_FALSE(tpkt_frame_length(Bytes{0x04, 0x00, 0x00, 0x10}).ok());
}

TEST(Protocol, computes_pdu_limits_of_the_spec) {
  EXPECT_EQ(read_request_size(19), 240u);
  EXPECT_EQ(max_read_bytes(240), 222u);
  EXPECT_EQ(read_reply_base() + reply_item_size(222), 240u);
}

}  // namespace
}  // namespace rtplc::s7
