// The libmodbus client against the fake slave (client.h, fake_slave.h): values
// both ways, and each magic-address fault seen as the outcome it must be.
#include <gtest/gtest.h>

#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/tests/client_checks.h"

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
  Outcome read_hr(uint16_t start, uint16_t count) { return testing::read_hr(client_, start, count); }
  std::unique_ptr<FakeSlave> slave_;
  Client client_;
};

TEST_F(ModbusClient, reads_and_writes_every_table) {
  ASSERT_NO_FATAL_FAILURE(testing::expect_values_both_ways(*slave_, client_));
  slave_->set(Table::kInputRegister, 7, 0xFFFF);
  uint16_t w[2] = {};
  ASSERT_TRUE(client_.read(Table::kInputRegister, 7, 1, w).ok());
  EXPECT_EQ(decode(*parse_address("ir:7:i16"), w), -1);
  w[0] = 513;
  ASSERT_TRUE(client_.write(*parse_address("hr:20"), w).ok());
  EXPECT_EQ(slave_->get(Table::kHoldingRegister, 20), 513);
}

TEST_F(ModbusClient, magic_addresses_answer_with_each_exception_by_name) {
  testing::expect_each_exception_by_name(client_);
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
