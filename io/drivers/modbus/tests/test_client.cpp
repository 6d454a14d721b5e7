// The libmodbus client against the fake slave (client.h, fake_slave.h): values
// both ways, and each magic-address fault seen as the outcome it must be.
#include <gtest/gtest.h>

#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"

namespace rtplc::modbus {
namespace {

class ModbusClient : public ::testing::Test {
 protected:
  void SetUp() override {
    FakeSlaveOptions o;
    o.delay_ns = 300000000;
    slave_ = std::make_unique<FakeSlave>(o);
    ASSERT_TRUE(slave_->start().ok());
    auto c = Client::tcp("127.0.0.1", slave_->port());
    ASSERT_TRUE(c.ok());
    client_ = std::move(*c);
    client_.set_timeout_ns(150000000);
    ASSERT_TRUE(client_.connect().ok());
  }
  Outcome read_hr(uint16_t start, uint16_t count) {
    uint16_t w[125];
    return client_.read(Table::kHoldingRegister, start, count, w);
  }
  std::unique_ptr<FakeSlave> slave_;
  Client client_;
};

TEST_F(ModbusClient, reads_and_writes_every_table) {
  slave_->put(*parse_address("hr:4:f32"), 21.5);
  slave_->set(Table::kDiscreteInput, 3, 1);
  slave_->set(Table::kInputRegister, 7, 0xFFFF);
  uint16_t w[2] = {};
  ASSERT_TRUE(client_.read(Table::kHoldingRegister, 4, 2, w).ok());
  EXPECT_EQ(decode(*parse_address("hr:4:f32"), w), 21.5);
  ASSERT_TRUE(client_.read(Table::kDiscreteInput, 3, 1, w).ok());
  EXPECT_EQ(w[0], 1);
  ASSERT_TRUE(client_.read(Table::kInputRegister, 7, 1, w).ok());
  EXPECT_EQ(decode(*parse_address("ir:7:i16"), w), -1);
  const Address pair = *parse_address("hr:22:f32:swapped");
  encode(pair, -3.25, w);
  ASSERT_TRUE(client_.write(pair, w).ok());
  EXPECT_EQ(slave_->value(pair), -3.25);
  w[0] = 1;
  ASSERT_TRUE(client_.write(*parse_address("coil:21"), w).ok());
  EXPECT_EQ(slave_->get(Table::kCoil, 21), 1);
  w[0] = 513;
  ASSERT_TRUE(client_.write(*parse_address("hr:20"), w).ok());
  EXPECT_EQ(slave_->get(Table::kHoldingRegister, 20), 513);
}

TEST_F(ModbusClient, magic_addresses_answer_with_each_exception_by_name) {
  for (int code : {1, 2, 3, 4, 6, 11}) {
    const Outcome o = read_hr(static_cast<uint16_t>(kMagicExceptionBase + code), 1);
    EXPECT_EQ(o.kind, Outcome::Kind::kException) << code;
    EXPECT_EQ(o.code, code);
  }
  EXPECT_EQ(outcome_text(read_hr(kMagicExceptionBase + 2, 1)), "illegal data address (exception 2)");
  EXPECT_TRUE(read_hr(0, 10).ok());  // the connection survives exceptions
}

TEST_F(ModbusClient, silence_and_delay_are_timeouts_and_the_link_recovers) {
  EXPECT_EQ(read_hr(kMagicSilent, 1).kind, Outcome::Kind::kTimeout);
  EXPECT_EQ(read_hr(kMagicDelay, 1).kind, Outcome::Kind::kTimeout);
  client_.flush();
  usleep(400000);  // the delayed answer arrives late and must not be taken for the next one
  client_.flush();
  EXPECT_TRUE(read_hr(0, 1).ok());
}

TEST_F(ModbusClient, a_dropped_connection_and_bad_frames_are_told_apart) {
  EXPECT_NE(read_hr(kMagicBadId, 1).kind, Outcome::Kind::kOk);
  client_.flush();
  ASSERT_TRUE(client_.connect().ok());
  EXPECT_NE(read_hr(kMagicBadLength, 1).kind, Outcome::Kind::kOk);
  ASSERT_TRUE(client_.connect().ok());
  const Outcome o = read_hr(kMagicDrop, 1);
  EXPECT_TRUE(o.kind == Outcome::Kind::kLink || o.kind == Outcome::Kind::kTimeout) << outcome_text(o);
  ASSERT_TRUE(client_.connect().ok());
  EXPECT_TRUE(read_hr(0, 1).ok());
}

TEST_F(ModbusClient, a_killed_slave_refuses_and_a_restarted_one_answers) {
  slave_->kill();
  EXPECT_FALSE(read_hr(0, 1).ok());
  EXPECT_FALSE(client_.connect().ok());
  ASSERT_TRUE(slave_->restart().ok());
  ASSERT_TRUE(client_.connect().ok());
  EXPECT_TRUE(read_hr(0, 1).ok());
}

}  // namespace
}  // namespace rtplc::modbus
