// The master's request frames and answer checks (request.h), byte for byte:
// the request examples of the Modbus Application Protocol specification
// (v1.1b3, section 6) framed in MBAP by hand, each read back by the slave
// side's own parser (pdu.h), and answers that are right, refused, or wrong in
// each way a slave can get them wrong.
#include <gtest/gtest.h>

#include <modbus/modbus.h>

#include <vector>

#include "io/drivers/modbus/pdu.h"
#include "io/drivers/modbus/request.h"

namespace rtplc::modbus {
namespace {

std::vector<uint8_t> frame_of(const Asked& rq, uint16_t tid) {
  uint8_t buf[kMaxRequestFrame];
  const size_t n = frame_request(rq, tid, buf);
  return {buf, buf + n};
}

// An answer frame around `pdu`, as a slave sends it.
struct Answer {
  std::vector<uint8_t> bytes;
  Frame frame;
};
Answer answer(uint8_t unit, std::vector<uint8_t> pdu, uint16_t tid = 1) {
  Answer a;
  append_frame(a.bytes, tid, unit, pdu.data(), pdu.size());
  EXPECT_EQ(next_frame(a.bytes.data(), a.bytes.size(), a.frame), FrameStatus::kComplete);
  return a;
}

TEST(ModbusRequest, reads_are_framed_as_the_specification_s_examples) {
  // Holding registers 108-110 (address 0x006B, 3 registers), unit 0x11.
  EXPECT_EQ(frame_of(read_request(0x11, Table::kHoldingRegister, 0x006B, 3), 0x0102),
            (std::vector<uint8_t>{0x01, 0x02, 0x00, 0x00, 0x00, 0x06, 0x11, 0x03, 0x00, 0x6B, 0x00, 0x03}));
  // Coils 20-38 (address 0x0013, 19 coils).
  EXPECT_EQ(frame_of(read_request(1, Table::kCoil, 0x0013, 19), 7),
            (std::vector<uint8_t>{0x00, 0x07, 0x00, 0x00, 0x00, 0x06, 0x01, 0x01, 0x00, 0x13, 0x00, 0x13}));
  EXPECT_EQ(frame_of(read_request(1, Table::kDiscreteInput, 0x00C4, 22), 1)[7], 2);
  EXPECT_EQ(frame_of(read_request(1, Table::kInputRegister, 0x0008, 1), 1)[7], 4);
}

TEST(ModbusRequest, writes_are_framed_as_the_specification_s_examples_and_parse_as_the_slave_reads_them) {
  const uint16_t on[1] = {1};
  // Coil 173 ON: FC 5, 0x00AC, 0xFF00.
  EXPECT_EQ(frame_of(write_request(1, *parse_address("coil:172"), on), 3),
            (std::vector<uint8_t>{0x00, 0x03, 0x00, 0x00, 0x00, 0x06, 0x01, 0x05, 0x00, 0xAC, 0xFF, 0x00}));
  const uint16_t reg[1] = {0x0003};
  // Register 2 = 3: FC 6, 0x0001, 0x0003.
  EXPECT_EQ(frame_of(write_request(1, *parse_address("hr:1"), reg), 4),
            (std::vector<uint8_t>{0x00, 0x04, 0x00, 0x00, 0x00, 0x06, 0x01, 0x06, 0x00, 0x01, 0x00, 0x03}));
  const uint16_t pair[2] = {0x000A, 0x0102};
  // Registers 2-3 = 0x000A 0x0102: FC 16, 0x0001, 2 registers, 4 bytes.
  const std::vector<uint8_t> f16 = frame_of(write_request(1, *parse_address("hr:1:u32"), pair), 5);
  EXPECT_EQ(f16, (std::vector<uint8_t>{0x00, 0x05, 0x00, 0x00, 0x00, 0x0B, 0x01, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04,
                                       0x00, 0x0A, 0x01, 0x02}));
  EXPECT_EQ(f16.size(), kMaxRequestFrame);
  Frame f;
  ASSERT_EQ(next_frame(f16.data(), f16.size(), f), FrameStatus::kComplete);
  Request rq;
  ASSERT_EQ(parse_request(f.pdu, f.pdu_len, rq), 0);
  EXPECT_EQ(rq.function, 16);
  EXPECT_EQ(rq.address, 1);
  EXPECT_EQ(rq.count, 2);
  EXPECT_EQ(rq.register_at(1), 0x0102);
}

TEST(ModbusRequest, answers_carry_their_values) {
  uint16_t w[32] = {};
  // Three registers: 0x022B 0x0000 0x0064.
  const Asked hr = read_request(0x11, Table::kHoldingRegister, 0x006B, 3);
  Answer a = answer(0x11, {0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64});
  ASSERT_TRUE(check_answer(hr, a.frame, w).ok());
  EXPECT_EQ(w[0], 0x022B);
  EXPECT_EQ(w[2], 0x0064);
  // 19 coils: 0xCD 0x6B 0x05 (coil 20 is bit 0 of the first byte).
  const Asked coils = read_request(1, Table::kCoil, 0x0013, 19);
  a = answer(1, {0x01, 0x03, 0xCD, 0x6B, 0x05});
  ASSERT_TRUE(check_answer(coils, a.frame, w).ok());
  const uint16_t want[19] = {1, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 1, 1, 0, 1, 0, 1};
  for (int i = 0; i < 19; ++i) EXPECT_EQ(w[i], want[i]) << i;
  // Writes: the echo.
  const uint16_t on[1] = {1};
  a = answer(1, {0x05, 0x00, 0xAC, 0xFF, 0x00});
  EXPECT_TRUE(check_answer(write_request(1, *parse_address("coil:172"), on), a.frame, w).ok());
  const uint16_t pair[2] = {0x000A, 0x0102};
  a = answer(1, {0x10, 0x00, 0x01, 0x00, 0x02});
  EXPECT_TRUE(check_answer(write_request(1, *parse_address("hr:1:u32"), pair), a.frame, w).ok());
}

TEST(ModbusRequest, a_refusal_is_an_exception_with_its_code) {
  uint16_t w[4];
  const Asked rq = read_request(1, Table::kInputRegister, 8, 1);
  Answer a = answer(1, {0x84, 0x02});
  const Outcome o = check_answer(rq, a.frame, w);
  EXPECT_EQ(o.kind, Outcome::Kind::kException);
  EXPECT_EQ(o.code, 2);
  EXPECT_EQ(outcome_text(o), "illegal data address (exception 2)");
}

TEST(ModbusRequest, wrong_answers_are_protocol_errors_never_values) {
  uint16_t w[8] = {};
  const Asked rq = read_request(1, Table::kHoldingRegister, 0, 2);
  auto kind = [&](uint8_t unit, std::vector<uint8_t> pdu) {
    Answer a = answer(unit, std::move(pdu));
    return check_answer(rq, a.frame, w);
  };
  EXPECT_EQ(kind(2, {0x03, 0x04, 0, 1, 0, 2}).code, EMBBADSLAVE);                 // another unit
  EXPECT_EQ(kind(1, {0x04, 0x04, 0, 1, 0, 2}).kind, Outcome::Kind::kProtocol);    // another function
  EXPECT_EQ(kind(1, {0x03, 0x06, 0, 1, 0, 2, 0, 0}).kind, Outcome::Kind::kProtocol);  // too many registers
  EXPECT_EQ(kind(1, {0x03, 0x04, 0, 1, 0}).kind, Outcome::Kind::kProtocol);       // cut short
  EXPECT_EQ(kind(1, {0x03, 0x02, 0, 1, 0, 2}).kind, Outcome::Kind::kProtocol);    // count and length disagree
  EXPECT_EQ(kind(1, {0x83}).kind, Outcome::Kind::kProtocol);                      // an exception without its code
  EXPECT_EQ(kind(1, {0x83, 0x00}).kind, Outcome::Kind::kProtocol);                // exception 0
  EXPECT_EQ(kind(1, {0x81, 0x02}).kind, Outcome::Kind::kProtocol);                // another function's exception
  const uint16_t reg[1] = {7};
  const Asked wr = write_request(1, *parse_address("hr:3"), reg);
  Answer a = answer(1, {0x06, 0x00, 0x03, 0x00, 0x08});  // echoes another value
  EXPECT_EQ(check_answer(wr, a.frame, w).kind, Outcome::Kind::kProtocol);
  a = answer(1, {0x06, 0x00, 0x03, 0x00, 0x07});
  EXPECT_TRUE(check_answer(wr, a.frame, w).ok());
}

}  // namespace
}  // namespace rtplc::modbus
