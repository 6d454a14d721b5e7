// Modbus RTU (issue 9, items 1-3): the slave-side framing tables, our client
// against our fake slave on a socat pty pair (values, each exception by name,
// the RTU faults: bad CRC as its own outcome, wrong unit id, silence, a unit
// the line does not have), and the command line against the fake slave and
// against python3-pymodbus's RTU server. Parity N throughout: pyserial (under
// pymodbus) cannot set even parity on a pty here (tcsetattr EINVAL), and a pty
// has no UART to use parity anyway; it is the UART's business, not the protocol's.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/pdu.h"
#include "io/drivers/modbus/tests/client_checks.h"
#include "io/drivers/modbus/tests/fake_rtu_line.h"
#include "io/drivers/modbus/tests/pty_pair.h"
#include "tests/support/run_tool.h"

namespace rtplc::modbus {
namespace {

using testing::Child;
using testing::FakeRtuLine;
using testing::have_pymodbus;
using testing::PtyPair;

std::vector<uint8_t> rtu_frame(std::vector<uint8_t> body) {
  const uint16_t crc = crc16(body.data(), body.size());
  body.push_back(static_cast<uint8_t>(crc));
  body.push_back(static_cast<uint8_t>(crc >> 8));
  return body;
}

TEST(SlaveFrames, crc16_matches_the_specifications_example) {
  const uint8_t read_ten[] = {0x01, 0x03, 0x00, 0x00, 0x00, 0x0A};  // its CRC goes out as C5 CD
  EXPECT_EQ(crc16(read_ten, sizeof read_ten), 0xCDC5);
}

TEST(SlaveFrames, rtu_requests_are_cut_by_function_code) {
  const auto read = rtu_frame({7, 3, 0, 0, 0, 1});
  EXPECT_EQ(kRtuFrames.frame_length(read.data(), 5), 0);
  EXPECT_EQ(kRtuFrames.frame_length(read.data(), read.size()), 8);
  const auto write = rtu_frame({7, 16, 0, 4, 0, 2, 4, 1, 2, 3, 4});
  EXPECT_EQ(kRtuFrames.frame_length(write.data(), 6), 0);
  EXPECT_EQ(kRtuFrames.frame_length(write.data(), 10), 0);
  EXPECT_EQ(kRtuFrames.frame_length(write.data(), write.size()), 13);
  Frame r;
  ASSERT_TRUE(kRtuFrames.open(write.data(), write.size(), r));
  EXPECT_EQ(r.unit, 7);
  EXPECT_EQ(r.pdu_len, 10u);
}

TEST(SlaveFrames, tcp_frames_are_the_mbap_functions_the_server_uses) {
  const uint8_t pdu[] = {3, 0, 4, 0, 2};
  std::vector<uint8_t> framed;
  append_frame(framed, 0x1234, 9, pdu, sizeof pdu);
  EXPECT_EQ(kTcpFrames.frame_length(framed.data(), framed.size() - 1), 0);
  ASSERT_EQ(kTcpFrames.frame_length(framed.data(), framed.size()), static_cast<ptrdiff_t>(framed.size()));
  Frame by_ops, by_mbap;
  ASSERT_TRUE(kTcpFrames.open(framed.data(), framed.size(), by_ops));
  ASSERT_EQ(next_frame(framed.data(), framed.size(), by_mbap), FrameStatus::kComplete);
  EXPECT_EQ(by_ops.transaction, 0x1234);
  EXPECT_EQ(by_ops.unit, by_mbap.unit);
  EXPECT_EQ(by_ops.pdu, by_mbap.pdu);
  EXPECT_EQ(by_ops.pdu_len, sizeof pdu);
  std::vector<uint8_t> sealed;
  kTcpFrames.seal(by_ops, pdu, sizeof pdu, FrameFault::kNone, sealed);
  EXPECT_EQ(sealed, framed);
  kTcpFrames.seal(by_ops, pdu, sizeof pdu, FrameFault::kWrongId, sealed);
  EXPECT_EQ(sealed[1], 0x35);  // transaction + 1
}

TEST(SlaveFrames, rtu_requests_are_checked_by_parse_request_as_on_tcp) {
  FakeSlaveOptions o;
  o.serial.device = "unused";
  FakeSlave slave(o);
  // FC 5 with a value that is neither 0xFF00 nor 0: exception 3, nothing written.
  const auto f = rtu_frame({7, 5, 0, 9, 0x12, 0x34});
  const Response r = slave.respond(kRtuFrames, f.data(), f.size());
  ASSERT_EQ(r.action, Response::Action::kReply);
  EXPECT_EQ(r.bytes, rtu_frame({7, 0x85, kExceptionIllegalValue}));
  EXPECT_EQ(slave.get(Table::kCoil, 9), 0);
  EXPECT_EQ(slave.writes(), 0u);
}

TEST(SlaveFrames, the_fake_ignores_a_request_with_a_bad_crc_and_answers_the_next) {
  FakeSlaveOptions o;
  o.serial.device = "unused";
  FakeSlave slave(o);
  slave.set(Table::kHoldingRegister, 0, 0x1234);
  auto good = rtu_frame({7, 3, 0, 0, 0, 1});
  auto bad = good;
  bad[6] ^= 1;  // the CRC's low byte
  std::vector<uint8_t> in = bad;
  std::vector<Response> out;
  EXPECT_TRUE(slave.serve(kRtuFrames, in, out));
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(in.empty());  // resynchronised
  in = good;
  EXPECT_TRUE(slave.serve(kRtuFrames, in, out));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].action, Response::Action::kReply);
  EXPECT_EQ(out[0].bytes, rtu_frame({7, 3, 2, 0x12, 0x34}));
}

TEST(SlaveFrames, garbage_hangs_up_tcp_and_is_discarded_on_rtu) {
  FakeSlave slave;
  std::vector<Response> out;
  std::vector<uint8_t> tcp = {0, 1, 0, 9, 0, 6, 1, 3, 0, 0, 0, 1};  // protocol id 9
  EXPECT_FALSE(slave.serve(kTcpFrames, tcp, out));
  std::vector<uint8_t> rtu(300, 0x10);  // FC 16 with a byte count past any frame
  rtu[6] = 255;
  EXPECT_TRUE(slave.serve(kRtuFrames, rtu, out));
  EXPECT_TRUE(rtu.empty());
  EXPECT_TRUE(out.empty());
}

TEST(SlaveFrames, an_rtu_broadcast_is_done_and_never_answered) {
  FakeSlaveOptions o;
  o.serial.device = "unused";
  FakeSlave slave(o);
  const auto f = rtu_frame({0, 6, 0, 9, 0, 42});
  EXPECT_EQ(slave.respond(kRtuFrames, f.data(), f.size()).action, Response::Action::kSilent);
  EXPECT_EQ(slave.get(Table::kHoldingRegister, 9), 42);
}

// Our client against our fake slave on the two ends of a pty pair, unit 7 the
// only unit on the line.
class ModbusRtuClient : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!line_.available()) GTEST_SKIP() << line_.why();
    auto r = line_.start();
    ASSERT_TRUE(r.ok()) << r.error();
    auto c = Client::rtu(line_.master());
    ASSERT_TRUE(c.ok());
    client_ = std::move(*c);
    client_.set_timeout_ns(150000000);
    client_.set_unit(7);
    const Outcome o2 = client_.connect();
    ASSERT_TRUE(o2.ok()) << outcome_text(o2);
  }
  Outcome read_hr(uint16_t start, uint16_t count) { return testing::read_hr(client_, start, count); }
  FakeSlave& slave() { return line_.slave(); }
  FakeRtuLine line_{{7}, 300000000};  // kMagicDelay answers after 300 ms, past the client's timeout
  Client client_;
};

TEST_F(ModbusRtuClient, reads_and_writes_over_a_pty) { testing::expect_values_both_ways(slave(), client_); }

TEST_F(ModbusRtuClient, magic_addresses_answer_with_each_exception_by_name) {
  testing::expect_each_exception_by_name(client_);
  EXPECT_EQ(outcome_text(read_hr(kMagicExceptionBase + 4, 1)), "slave device failure (exception 4)");
  EXPECT_TRUE(read_hr(0, 10).ok());
}

TEST_F(ModbusRtuClient, a_bad_crc_is_its_own_outcome_and_the_line_goes_on) {
  const Outcome o = read_hr(kMagicBadCrc, 1);
  EXPECT_EQ(o.kind, Outcome::Kind::kBadCrc) << outcome_text(o);
  EXPECT_EQ(outcome_text(o), "bad CRC (the answer was corrupted on the line)");
  client_.flush();
  EXPECT_TRUE(read_hr(0, 1).ok());
}

TEST_F(ModbusRtuClient, wrong_unit_wrong_length_and_silence_are_told_apart) {
  EXPECT_EQ(read_hr(kMagicBadId, 1).kind, Outcome::Kind::kProtocol);
  client_.flush();
  EXPECT_EQ(read_hr(kMagicBadLength, 1).kind, Outcome::Kind::kProtocol);
  client_.flush();
  EXPECT_EQ(read_hr(kMagicSilent, 1).kind, Outcome::Kind::kTimeout);
  EXPECT_EQ(read_hr(kMagicDrop, 1).kind, Outcome::Kind::kTimeout);  // a serial line cannot be hung up
  EXPECT_EQ(read_hr(kMagicDelay, 1).kind, Outcome::Kind::kTimeout);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // the late answer must not be taken for the next
  client_.flush();
  EXPECT_TRUE(read_hr(0, 1).ok());
}

TEST_F(ModbusRtuClient, a_unit_the_line_does_not_have_times_out_and_the_others_still_answer) {
  client_.set_unit(8);
  EXPECT_EQ(read_hr(0, 1).kind, Outcome::Kind::kTimeout);
  client_.set_unit(7);
  EXPECT_TRUE(read_hr(0, 1).ok());
  EXPECT_EQ(slave().requests(), 2u);  // the fake heard both; unit 8 is not there to answer
}

// The command line over a pty: against our fake slave, then pymodbus.
TEST(ModbusRtuCli, read_write_and_scan_reach_the_fake_slave_over_a_pty) {
  PtyPair pty;
  if (!pty.available()) GTEST_SKIP() << pty.why();
  const std::string bin = test::rtplc_binary();
  Child fake(bin.c_str(), "modbus", "fake-slave", "--rtu", pty.a().c_str(), "--parity", "N", "--unit", "7", "--set",
             "hr:3=42");
  const std::string line = " --rtu " + pty.b() + " --parity N --unit 7 --timeout 300 ";
  test::ToolRun r;
  for (int i = 0; i < 100; ++i) {  // until the fake has opened its end
    r = test::run_tool("modbus read" + line + "hr:3");
    if (r.status == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out, "hr:3 = 42\n");
  r = test::run_tool("modbus write" + line + "hr:20=513");
  EXPECT_EQ(r.status, 0) << r.out;
  r = test::run_tool("modbus read" + line + "hr:20 hr:65282 hr:65505");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("hr:20 = 513"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("hr:65282: illegal data address (exception 2)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("hr:65505: bad CRC"), std::string::npos) << r.out;
  r = test::run_tool("modbus scan --rtu " + pty.b() + " --parity N --from 5 --to 8");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("unit 7 answers (hr:0 = 0)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 unit(s) answered of 5..8"), std::string::npos) << r.out;
}

TEST(ModbusRtuCli, fake_slave_refuses_options_of_the_other_transport) {
  auto r = test::run_tool("modbus fake-slave --rtu /tmp/nowhere --port 1502");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--port applies to TCP only"), std::string::npos) << r.out;
  r = test::run_tool("modbus fake-slave --baud 9600");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--baud applies to RTU only"), std::string::npos) << r.out;
  r = test::run_tool("modbus fake-slave --rtu /tmp/rtplc-no-such-tty");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("cannot open /tmp/rtplc-no-such-tty"), std::string::npos) << r.out;
}

TEST(ModbusRtuCli, reads_a_pymodbus_rtu_server_over_a_pty) {
  if (!have_pymodbus()) GTEST_SKIP() << "python3-pymodbus is not installed (scripts/setup-deps installs it)";
  PtyPair pty;
  if (!pty.available()) GTEST_SKIP() << pty.why();
  Child server("/usr/bin/python3", RTPLC_SOURCE_DIR "/io/drivers/modbus/tests/pymodbus_server.py", "--rtu",
               pty.a().c_str());
  test::ToolRun r;
  for (int i = 0; i < 100; ++i) {  // until python has started and opened its end
    r = test::run_tool("modbus read --rtu " + pty.b() + " --parity N --unit 7 --timeout 300 hr:0");
    if (r.status == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out, "hr:0 = 17\n");
  r = test::run_tool("modbus write --rtu " + pty.b() + " --parity N --unit 7 hr:5=99");
  EXPECT_EQ(r.status, 0) << r.out;
  r = test::run_tool("modbus read --rtu " + pty.b() + " --parity N --unit 7 hr:5");
  EXPECT_EQ(r.out, "hr:5 = 99\n");
}

}  // namespace
}  // namespace rtplc::modbus
