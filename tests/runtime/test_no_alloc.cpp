// Real-time hygiene: task threads and driver bridge threads allocate nothing
// once running (kernel_rt/cycle_scope.h). This binary replaces the global
// operator new (tests/support/alloc_counter.cpp) and counts every allocation
// made inside a cycle, on any thread,
// across a run with the sim, modbus, modbus-server and s7 drivers and their faults:
// a Modbus slave that goes silent, dies, comes back and refuses a write; a
// PLC that refuses a read, cannot take a write and drops off; a block error
// every cycle; set-points, forces, a swap and a rollback; and a
// SCADA client writing a set-point. CAN and GPIO bridges are driven by their
// own tests' rigs the same way (their fakes need no kernel), see
// io/drivers/can/tests and io/drivers/gpio/tests.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "io/drivers/modbus/address.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/s7/fake_plc.h"
#include "kernel_rt/cycle_scope.h"
#include "tests/support/alloc_counter.h"
#include "tests/support/eventually.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::eventually;
using rtplc::testing::RuntimeFixture;

// The hook counts: an allocation inside a scope on this thread is seen.
TEST(NoAllocation, the_counter_sees_an_allocation_inside_a_cycle) {
  testing::AllocationCounter count;
  {
    const kernel_rt::CycleScope scope;
    void* p = ::operator new(64);
    ::operator delete(p);
  }
  void* q = ::operator new(64);  // outside: not counted
  ::operator delete(q);
  EXPECT_EQ(count.in_cycles(), 1u);
}

const char* kProgram =
    "%%\nstime(0.01)\nF1 = prr(p1, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F3 = sub(F2, F1, 1)\nF4 = epi(F3, 4, 3)\npwr(F4, p1, d0, c1, \"ManiVal\")\n"
    "F5 = asp(d0, c1, 0, \"Divisor\")\nF6 = div(F1, F5)\ndao(F6, p0, d1, c0, \"Ratio\")\n"
    "F7 = dai(p0, d1, c0, \"Plant\")\ndao(F7, p0, d1, c1, \"PlantOut\")\n"
    "F8 = asp(d0, c2, 1, \"Big\")\npwr(F8, p1, d0, c4, \"BigOut\")\n"
    "F9 = era(p1, d0, c0, \"Volt\")\nF10 = asp(d0, c3, 1, \"Amps\")\newa(F10, p1, d0, c1, \"AmpsOut\")\n"
    "F11 = era(p1, d0, c2, \"Missing\")\nF12 = add(F9, F11)\ndao(F12, p0, d1, c2, \"Sum\")\nEND\n";

std::string config(uint16_t slave_port, uint16_t server_port, uint16_t plc_port) {
  return "tasks:\n  - {name: loop, program: p.fbd}\n"
         "drivers:\n"
         "  - kind: modbus\n    name: field\n    period: 5ms\n    slaves:\n"
         "      - {name: plc1, address: 127.0.0.1, port: " + std::to_string(slave_port) +
         ", poll: 10ms, timeout: 50ms, retries: 0}\n"
         "    read:\n      - {device: R, channel: p1.d0.c0, slave: plc1, address: 0, type: f32}\n"
         "    write:\n      - {device: R, channel: p1.d0.c1, slave: plc1, address: 2, type: f32}\n"
         "      - {device: R, channel: p1.d0.c4, slave: plc1, address: 65282, type: i16}\n"
         "  - kind: sim\n    name: plant\n    period: 5ms\n    plants:\n"
         "      - {model: 'fopdt:K=1,T=0.5,L=0.05', input: p0.d1.c0, output: p0.d1.c0}\n"
         "  - kind: modbus-server\n    name: scada\n    port: " + std::to_string(server_port) + "\n"
         "    expose:\n      - {label: ProcVal, table: ir, address: 0, type: f32}\n"
         "      - {label: Setpoint, table: hr, address: 0, type: f32}\n"
         "    writable: [Setpoint]\n"
         "  - kind: s7\n    plcs: [{name: panel01, address: 127.0.0.1, port: " + std::to_string(plc_port) +
         ", poll: 20ms}]\n"
         "    read: [{channel: p1.d0.c0, plc: panel01, item: DB10.DBD0:REAL},\n"
         "           {channel: p1.d0.c2, plc: panel01, item: DB99.DBD0:REAL}]\n"
         "    write: [{channel: p1.d0.c1, plc: panel01, item: DB10.DBW4:INT, scale: 0.01}]\n";
}

uint16_t free_port() {
  modbus::FakeSlave probe;  // binds port 0: the kernel's choice
  if (!probe.start().ok()) return 0;
  const uint16_t p = probe.port();
  probe.stop();
  return p;
}

TEST(NoAllocation, task_and_bridge_threads_allocate_nothing_after_start_whatever_happens) {
  modbus::FakeSlave slave;
  ASSERT_TRUE(slave.start().ok());
  slave.put(*modbus::parse_address("hr:0:f32"), 20.0);
  const uint16_t server_port = free_port();
  ASSERT_NE(server_port, 0);
  s7::FakePlc plc;
  ASSERT_TRUE(plc.add_endpoint({"127.0.0.1", 0, {}}).ok());
  ASSERT_TRUE(plc.start().ok());
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  auto rt = fx.start(config(slave.port(), server_port, plc.port(0)));
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(eventually([&] { return testing::channel_value(*rt, "ProcVal") == 20.0; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // warm: first cycles of every thread
  testing::AllocationCounter count;

  // Operator actions (the control side allocates; the cycles must not).
  EXPECT_TRUE(rt->set_value("Setpoint", 30).ok());
  EXPECT_TRUE(rt->force("ProcVal", 25, 0).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(rt->unforce("ProcVal").ok());
  const std::string v2 = std::string(kProgram).replace(std::string(kProgram).find("epi(F3, 4, 3)"), 13, "epi(F3, 2, 3)");
  EXPECT_TRUE(rt->swap("loop", v2, "p2.fbd").ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(rt->rollback("loop").ok());
  // A SCADA client writes a set-point through modbus-server.
  {
    auto c = modbus::Client::tcp("127.0.0.1", server_port);
    ASSERT_TRUE(c.ok()) << c.error();
    ASSERT_TRUE(c->connect().ok());
    const modbus::Address sp = *modbus::parse_address("hr:0:f32");
    uint16_t words[4] = {};
    modbus::encode(sp, 35.0, words);
    EXPECT_TRUE(c->write(sp, words).ok());
    EXPECT_TRUE(eventually([&] { return testing::channel_value(*rt, "Setpoint") == 35.0; }));
  }
  // The slave refuses a write (its fake answers exception 2 at this address);
  // a value that does not fit its register.
  EXPECT_TRUE(rt->set_value("Big", 5).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(rt->set_value("Big", 100000).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  // S7: a write that does not fit its INT (the read of DB99 is refused all along).
  EXPECT_TRUE(rt->set_value("Amps", 1000).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  plc.kill(0);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  plc.restart(0);
  // Link faults: silent, dead, back.
  slave.set_silent(true);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  slave.set_silent(false);
  slave.kill();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_TRUE(slave.restart().ok());
  EXPECT_TRUE(eventually([&] { return testing::channel_value(*rt, "ProcVal") == 20.0; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const uint64_t n = count.in_cycles();
  rt->stop();
  EXPECT_EQ(n, 0u) << "first allocation inside a cycle on thread '" << count.first_thread() << "'";
}

}  // namespace
}  // namespace rtplc::sched
