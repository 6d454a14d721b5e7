// What the client must do the same over every transport (TCP and RTU), against
// the fake slave: carry values both ways, and answer each magic exception
// address with that exception by name. Call them under
// ASSERT_NO_FATAL_FAILURE (they stop at the first failed request).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>

#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"

namespace rtplc::modbus::testing {

inline Outcome read_hr(Client& client, uint16_t start, uint16_t count) {
  uint16_t w[125];
  return client.read(Table::kHoldingRegister, start, count, w);
}

// A float in two holding registers and a discrete input read; a swapped
// float pair and a coil written.
inline void expect_values_both_ways(FakeSlave& slave, Client& client) {
  slave.put(*parse_address("hr:4:f32"), 21.5);
  slave.set(Table::kDiscreteInput, 3, 1);
  uint16_t w[2] = {};
  ASSERT_TRUE(client.read(Table::kHoldingRegister, 4, 2, w).ok());
  EXPECT_EQ(decode(*parse_address("hr:4:f32"), w), 21.5);
  ASSERT_TRUE(client.read(Table::kDiscreteInput, 3, 1, w).ok());
  EXPECT_EQ(w[0], 1);
  const Address pair = *parse_address("hr:22:f32:swapped");
  encode(pair, -3.25, w);
  ASSERT_TRUE(client.write(pair, w).ok());
  EXPECT_EQ(slave.value(pair), -3.25);
  w[0] = 1;
  ASSERT_TRUE(client.write(*parse_address("coil:21"), w).ok());
  EXPECT_EQ(slave.get(Table::kCoil, 21), 1);
}

inline void expect_each_exception_by_name(Client& client) {
  for (int code : {1, 2, 3, 4, 6, 11}) {
    const Outcome o = read_hr(client, static_cast<uint16_t>(kMagicExceptionBase + code), 1);
    EXPECT_EQ(o.kind, Outcome::Kind::kException) << code;
    EXPECT_EQ(o.code, code);
  }
  EXPECT_EQ(outcome_text(read_hr(client, kMagicExceptionBase + 2, 1)), "illegal data address (exception 2)");
}

}  // namespace rtplc::modbus::testing
