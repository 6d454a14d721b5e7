// The modbus driver inside a running runtime (issue 9, items 1 and 4), against
// the fake slave: reads land in the image with quality, writes reach the slave,
// a killed slave turns exactly its channels bad (last value kept) and good
// again when it is back, with its outputs sent again; a slave that never
// answers beside a healthy one costs the healthy one no poll; an exception
// marks only its item's block bad. Also against python3-pymodbus when installed.
// RTU over a socat pty pair (parity N: pyserial, under pymodbus, cannot set
// even parity on a pty here): two units on one line where one is dead, and pymodbus's RTU server.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <thread>

#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/tests/fake_rtu_line.h"
#include "io/drivers/modbus/tests/pty_pair.h"
#include "sched/stats_source.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/eventually.h"

namespace rtplc::sched {
namespace {

using modbus::FakeSlave;
using modbus::testing::FakeRtuLine;
using modbus::parse_address;
using rtplc::testing::RuntimeFixture;

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

using rtplc::testing::eventually;

const char* kProgram =
    "%%\nstime(0.02)\nF1 = prr(p1, d0, c0, \"Level\")\nF2 = scale(F1, 2, 1)\n"
    "D3 = prx(p1, d0, c2, \"Run\")\nF4 = prr(p2, d0, c0, \"Other\")\nF5 = prr(p1, d0, c5, \"Refused\")\n"
    "pwr(F2, p1, d0, c1, \"Out\")\npwy(D3, p1, d0, c3, \"Lamp\")\nEND\n";

std::string config(uint16_t port_a, uint16_t port_b) {
  return "tasks:\n  - {name: t, program: p.fbd}\n"
         "drivers:\n  - kind: modbus\n    name: mb\n    period: 10ms\n    slaves:\n"
         "      - {name: a, address: 127.0.0.1, port: " + std::to_string(port_a) +
         ", poll: 20ms, timeout: 100ms, retries: 0}\n"
         "      - {name: b, address: 127.0.0.1, port: " + std::to_string(port_b) +
         ", poll: 20ms, timeout: 100ms, retries: 0}\n"
         "    read:\n"
         "      - {device: R, channel: p1.d0.c0, slave: a, address: 0, type: f32}\n"
         "      - {device: X, channel: p1.d0.c2, slave: a, address: 2}\n"
         "      - {device: R, channel: p1.d0.c5, slave: a, address: 65282}\n"
         "      - {device: R, channel: p2.d0.c0, slave: b, address: 0, scale: 0.1}\n"
         "    write:\n"
         "      - {device: R, channel: p1.d0.c1, slave: a, address: 10, type: f32, word_order: low_first}\n"
         "      - {device: Y, channel: p1.d0.c3, slave: a, address: 3}\n";
}

class ModbusRuntime : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(a_.start().ok());
    ASSERT_TRUE(b_.start().ok());
    a_.put(*parse_address("hr:0:f32"), 2.5);
    a_.set(modbus::Table::kDiscreteInput, 2, 1);
    b_.set(modbus::Table::kHoldingRegister, 0, 123);
    fx_.write("p.fbd", kProgram);
  }
  void TearDown() override {
    if (rt_) rt_->stop();
  }
  io::ChannelValue channel(const char* label) {
    return rt_->image().read_channel(static_cast<uint32_t>(rt_->image().find_channel(label)));
  }
  double out_a() const { return a_.value(*parse_address("hr:10:f32:swapped")); }

  FakeSlave a_, b_;
  RuntimeFixture fx_;
  std::unique_ptr<Runtime> rt_;
};

TEST_F(ModbusRuntime, values_flow_from_the_slave_through_the_task_back_to_the_slave) {
  rt_ = fx_.start(config(a_.port(), b_.port()));
  ASSERT_NE(rt_, nullptr);
  ASSERT_TRUE(eventually([&] { return out_a() == 6.0; })) << out_a();  // 2.5 * 2 + 1
  EXPECT_EQ(channel("Level").value, 2.5);
  EXPECT_EQ(channel("Level").quality, Quality::kGood);
  EXPECT_EQ(channel("Other").value, 12.3);
  EXPECT_TRUE(eventually([&] { return a_.get(modbus::Table::kCoil, 3) == 1; }));
  // The item behind an exception is bad; the others of that slave are not.
  EXPECT_EQ(channel("Refused").quality, Quality::kBad);
  a_.put(*parse_address("hr:0:f32"), -1.0);
  EXPECT_TRUE(eventually([&] { return out_a() == -1.0; }));
  const io::LinkStatus& ls = rt_->image().link(0);
  EXPECT_TRUE(eventually([&] { return ls.writes_acked.load() >= 2u; }));
  EXPECT_EQ(ls.state.load(), static_cast<uint8_t>(io::LinkState::kUp));
  EXPECT_GT(ls.errors.load(), 0u);  // the exception answers
}

TEST_F(ModbusRuntime, a_force_the_register_cannot_carry_is_refused_naming_the_item) {
  std::string cfg = config(a_.port(), b_.port());
  const std::string f32 = "address: 10, type: f32, word_order: low_first";
  ASSERT_NE(cfg.find(f32), std::string::npos);
  cfg.replace(cfg.find(f32), f32.size(), "address: 10, scale: 0.5");  // u16 raw = value / 0.5
  rt_ = fx_.start(cfg);
  ASSERT_NE(rt_, nullptr);
  Result<std::string> r = rt_->force("Out", 40000, 0);  // raw 80000 > 65535
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("driver mb sends \"Out\" and slave a item hr:10"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("cannot carry 40000 (raw 80000)"), std::string::npos) << r.error();
  EXPECT_TRUE(rt_->forces().empty());
  r = rt_->force("Out", 100, 0);
  EXPECT_TRUE(r.ok()) << r.error();
}

TEST_F(ModbusRuntime, a_killed_slave_turns_exactly_its_channels_bad_and_recovers_with_outputs_resent) {
  rt_ = fx_.start(config(a_.port(), b_.port()));
  ASSERT_NE(rt_, nullptr);
  ASSERT_TRUE(eventually([&] { return channel("Level").quality == Quality::kGood && out_a() == 6.0; }));
  a_.kill();
  ASSERT_TRUE(eventually([&] { return channel("Level").quality == Quality::kBad; }));
  EXPECT_EQ(channel("Level").value, 2.5);  // the last value stays
  EXPECT_EQ(channel("Other").quality, Quality::kGood);  // the other slave is untouched
  a_.set(modbus::Table::kHoldingRegister, 10, 0);        // a restarted slave holds its reset values
  a_.set(modbus::Table::kHoldingRegister, 11, 0);
  a_.set(modbus::Table::kCoil, 3, 0);
  ASSERT_TRUE(a_.restart().ok());
  EXPECT_TRUE(eventually([&] { return channel("Level").quality == Quality::kGood; }));
  EXPECT_TRUE(eventually([&] { return out_a() == 6.0 && a_.get(modbus::Table::kCoil, 3) == 1; }));
  EXPECT_GE(rt_->image().link(0).reconnects.load(), 1u);
}

TEST_F(ModbusRuntime, a_slave_that_never_answers_costs_the_healthy_one_no_poll) {
  b_.set_silent(true);
  rt_ = fx_.start(config(a_.port(), b_.port()));
  ASSERT_NE(rt_, nullptr);
  ASSERT_TRUE(eventually([&] { return channel("Level").quality == Quality::kGood; }));
  sleep_s(1.0);
  EXPECT_EQ(channel("Other").quality, Quality::kBad);
  const io::LinkStatus& a = rt_->image().link(0);
  const io::LinkStatus& b = rt_->image().link(1);
  EXPECT_GT(b.timeouts.load(), 0u);
  EXPECT_GT(a.polls_completed.load(), 20u);
  // Waiting on the silent slave (100 ms timeouts, 20 ms polls) would cost the
  // healthy one about five polls per poll made; a host that stalls the machine
  // for a period now and then may cost it one. (Zero failed once that way.)
  EXPECT_LE(a.polls_missed.load(), a.polls_completed.load() / 10);
  EXPECT_EQ(a.timeouts.load(), 0u);
}

TEST(ModbusRuntimeConfig, bad_maps_are_refused_with_their_position) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  std::string errors;
  auto rt = fx.load(
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: modbus\n    slaves: [{name: a, address: plc.example}]\n"
      "    write: [{device: X, channel: p1.d0.c1, slave: a, address: 1}]\n"
      "    read: [{device: Y, channel: p1.d0.c0, slave: nobody, address: 1, type: f32}]\n",
      &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("numeric IPv4"), std::string::npos) << errors;
  EXPECT_NE(errors.find("a master cannot write"), std::string::npos) << errors;
  EXPECT_NE(errors.find("'type' applies to R"), std::string::npos) << errors;
}

// pymodbus as an independent slave: python3-pymodbus from Debian.
TEST(ModbusPymodbus, our_master_reads_and_writes_a_pymodbus_server) {
  if (std::system("/usr/bin/python3 -c 'import pymodbus' >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "python3-pymodbus is not installed (scripts/setup-deps installs it)";
  }
  const uint16_t port = static_cast<uint16_t>(20000 + getpid() % 20000);
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string p = std::to_string(port);
    execl("/usr/bin/python3", "python3", RTPLC_SOURCE_DIR "/io/drivers/modbus/tests/pymodbus_server.py", p.c_str(),
           static_cast<char*>(nullptr));
    _exit(127);
  }
  RuntimeFixture fx;
  fx.write("p.fbd",
           "%%\nstime(0.02)\nF1 = prr(p1, d0, c0, \"Level\")\nF2 = scale(F1, 2, 1)\n"
           "pwr(F2, p1, d0, c1, \"Out\")\nEND\n");
  const std::string cfg =
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: modbus\n    name: mb\n    slaves:\n"
      "      - {name: py, address: 127.0.0.1, port: " + std::to_string(port) + ", poll: 20ms}\n"
      "    read: [{device: R, channel: p1.d0.c0, slave: py, address: 0}]\n"
      "    write: [{device: R, channel: p1.d0.c1, slave: py, address: 1}]\n";
  auto rt = fx.start(cfg);
  ASSERT_NE(rt, nullptr);
  auto ch = [&](const char* l) { return rt->image().read_channel(static_cast<uint32_t>(rt->image().find_channel(l))); };
  // The server starts with hr0 = 17; our write of 35 to hr1 is acknowledged by it.
  EXPECT_TRUE(eventually([&] { return ch("Level").quality == Quality::kGood && ch("Level").value == 17; }, 15));
  EXPECT_TRUE(eventually([&] { return rt->image().link(0).writes_acked.load() > 0; }));
  rt->stop();
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
}

// An RTU line on a fieldbus plan inside a running runtime: its loop's item is
// read and good, the urgent write arrives, and its first slave's link row
// carries the plan and the per-class figures `rtplc stats` prints.
TEST(ModbusRtuRuntime, a_line_on_a_plan_shows_its_classes_in_its_link_row) {
  FakeRtuLine rtu({1});
  if (!rtu.available()) GTEST_SKIP() << rtu.why();
  ASSERT_TRUE(rtu.start().ok());
  FakeSlave& slave = rtu.slave();
  slave.put(*parse_address("hr:0:f32"), 2.5);
  RuntimeFixture fx;
  fx.write("p.fbd", "%%\nstime(0.02)\nF1 = prr(p1, d0, c0, \"Level\")\nF2 = scale(F1, 2, 1)\n"
                    "pwr(F2, p1, d0, c1, \"Out\")\nEND\n");
  fx.write("plan.yaml",
           "link: {nodes: 4, bit_rate: 19200, layout: modbus-rtu}\nperiodic: {bytes: 4}\n"
           "realtime: {queues: 1, bytes: 4}\nloops:\n  - {name: level, period: 100ms}\n");
  auto rt = fx.start("tasks:\n  - {name: t, program: p.fbd}\n"
                     "drivers:\n  - kind: modbus\n    name: mb\n    slaves:\n"
                     "      - {name: meter, unit: 1, timeout: 150ms, device: " + rtu.device() +
                     ", parity: N, plan: plan.yaml}\n"
                     "    read:\n"
                     "      - {device: R, channel: p1.d0.c0, slave: meter, address: 0, type: f32, loop: level}\n"
                     "    write:\n"
                     "      - {device: R, channel: p1.d0.c1, slave: meter, address: 10, type: f32}\n");
  ASSERT_NE(rt, nullptr);
  auto ch = [&](const char* l) { return rt->image().read_channel(static_cast<uint32_t>(rt->image().find_channel(l))); };
  const io::LinkStatus& row = rt->image().link(0);
  ASSERT_TRUE(eventually([&] { return ch("Level").quality == Quality::kGood; }));
  EXPECT_TRUE(eventually([&] { return slave.value(*parse_address("hr:10:f32")) == 6.0; }));  // 2.5 * 2 + 1
  ASSERT_TRUE(eventually([&] { return row.classes[0].count.load() >= 5 && row.classes[1].count.load() >= 1; }, 30));
  EXPECT_NE(std::string(row.plan).find("plan.yaml: T1 100ms"), std::string::npos) << row.plan;
  EXPECT_STREQ(row.classes[0].name, "periodic");
  EXPECT_LE(row.classes[0].packet_max_ns.load(), row.classes[0].packet_bound_ns.load());
  const std::string text = sched::render_link_classes(sched::link_snapshot(row));
  EXPECT_NE(text.find("    periodic: "), std::string::npos) << text;
  EXPECT_NE(text.find("    urgent: "), std::string::npos) << text;
  rt->stop();
}

// Two units on one RTU line; the fake has only unit 1, so unit 2 is dead. Each
// poll of the dead unit costs the line its 30 ms timeout, well under the live
// unit's 200 ms period, so the live unit keeps its grid: no poll missed, no
// timeout (its own 150 ms leaves a loaded machine room). The dead one is polled less and less often (its skipped polls are
// counted offline) and its channel is bad, until it comes back, when it is
// counted reconnected and its output is sent again.
TEST(ModbusRtuRuntime, a_dead_unit_costs_the_live_one_on_its_line_no_poll_and_is_polled_less_often_until_it_answers) {
  FakeRtuLine rtu({1});
  if (!rtu.available()) GTEST_SKIP() << rtu.why();
  ASSERT_TRUE(rtu.start().ok());
  FakeSlave& slave = rtu.slave();
  slave.put(*parse_address("hr:0:f32"), 2.5);
  RuntimeFixture fx;
  fx.write("p.fbd",
           "%%\nstime(0.02)\nF1 = prr(p1, d0, c0, \"Level\")\nF2 = scale(F1, 2, 1)\n"
           "F3 = prr(p2, d0, c0, \"Dead\")\npwr(F2, p1, d0, c1, \"Out\")\npwr(F2, p2, d0, c1, \"DeadOut\")\nEND\n");
  const std::string line = "device: " + rtu.device() + ", parity: N, poll: 200ms, retries: 0";
  auto rt = fx.start("tasks:\n  - {name: t, program: p.fbd}\n"
                     "drivers:\n  - kind: modbus\n    name: mb\n    slaves:\n"
                     "      - {name: live, unit: 1, timeout: 150ms, " + line + "}\n"
                     "      - {name: dead, unit: 2, timeout: 30ms, " + line + "}\n"
                     "    read:\n"
                     "      - {device: R, channel: p1.d0.c0, slave: live, address: 0, type: f32}\n"
                     "      - {device: R, channel: p2.d0.c0, slave: dead, address: 5}\n"
                     "    write:\n"
                     "      - {device: R, channel: p1.d0.c1, slave: live, address: 10, type: f32}\n"
                     "      - {device: R, channel: p2.d0.c1, slave: dead, address: 20}\n");
  ASSERT_NE(rt, nullptr);
  auto ch = [&](const char* l) { return rt->image().read_channel(static_cast<uint32_t>(rt->image().find_channel(l))); };
  const io::LinkStatus& live = rt->image().link(0);
  const io::LinkStatus& dead = rt->image().link(1);
  ASSERT_TRUE(eventually([&] { return ch("Level").quality == Quality::kGood; }));
  EXPECT_TRUE(eventually([&] { return slave.value(*parse_address("hr:10:f32")) == 6.0; }));  // 2.5 * 2 + 1
  ASSERT_TRUE(eventually([&] { return live.polls_completed.load() >= 20; }, 30));
  EXPECT_EQ(ch("Level").quality, Quality::kGood);
  EXPECT_EQ(live.polls_missed.load(), 0u);
  EXPECT_EQ(live.timeouts.load(), 0u);
  EXPECT_EQ(ch("Dead").quality, Quality::kBad);
  EXPECT_EQ(dead.polls_completed.load(), 0u);
  const uint64_t attempts = dead.timeouts.load();
  EXPECT_GE(attempts, 2u);
  // Polled less often than asked: most of its due polls were skipped, and it
  // was tried far less often than the live unit was polled.
  EXPECT_GT(dead.polls_offline.load(), attempts) << dead.polls_offline.load() << " offline";
  EXPECT_LT(attempts * 3, live.polls_completed.load()) << attempts << " tries, " << live.polls_completed.load() << " live polls";
  EXPECT_EQ(dead.state.load(), static_cast<uint8_t>(io::LinkState::kDown));
  EXPECT_EQ(slave.get(modbus::Table::kHoldingRegister, 20), 0);  // its output never arrived
  // It comes up: answered at its next try, good, and its output sent now.
  slave.set(modbus::Table::kHoldingRegister, 5, 7);  // the units share the fake's tables
  slave.set_units({1, 2});
  EXPECT_TRUE(eventually([&] { return ch("Dead").quality == Quality::kGood; }, 30));
  EXPECT_EQ(ch("Dead").value, 7);
  EXPECT_TRUE(eventually([&] { return slave.get(modbus::Table::kHoldingRegister, 20) == 6; }));
  EXPECT_EQ(dead.reconnects.load(), 0u);
  // It goes and comes back with its reset values: counted reconnected, and its
  // output (delivered before, unchanged since) is sent again.
  slave.set_units({1});
  EXPECT_TRUE(eventually([&] { return ch("Dead").quality == Quality::kBad; }));
  EXPECT_EQ(ch("Dead").value, 7);  // the last value stays
  slave.set(modbus::Table::kHoldingRegister, 20, 0);
  slave.set_units({1, 2});
  EXPECT_TRUE(eventually([&] { return slave.get(modbus::Table::kHoldingRegister, 20) == 6; }, 30));
  EXPECT_EQ(ch("Dead").quality, Quality::kGood);
  EXPECT_EQ(dead.reconnects.load(), 1u);
  EXPECT_EQ(live.polls_missed.load(), 0u);
  EXPECT_EQ(live.timeouts.load(), 0u);
  rt->stop();
}

TEST(ModbusRtuRuntime, our_driver_reads_and_writes_a_pymodbus_rtu_server_over_a_pty) {
  if (!modbus::testing::have_pymodbus()) {
    GTEST_SKIP() << "python3-pymodbus is not installed (scripts/setup-deps installs it)";
  }
  modbus::testing::PtyPair pty;
  if (!pty.available()) GTEST_SKIP() << pty.why();
  modbus::testing::Child server("/usr/bin/python3", RTPLC_SOURCE_DIR "/io/drivers/modbus/tests/pymodbus_server.py",
                                "--rtu", pty.a().c_str());
  RuntimeFixture fx;
  fx.write("p.fbd",
           "%%\nstime(0.02)\nF1 = prr(p1, d0, c0, \"Level\")\nF2 = scale(F1, 2, 1)\n"
           "pwr(F2, p1, d0, c1, \"Out\")\nEND\n");
  const std::string cfg =
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: modbus\n    name: mb\n    slaves:\n"
      "      - {name: py, device: " + pty.b() + ", parity: N, unit: 3, poll: 50ms, timeout: 200ms}\n"
      "    read: [{device: R, channel: p1.d0.c0, slave: py, address: 0}]\n"
      "    write: [{device: R, channel: p1.d0.c1, slave: py, address: 1}]\n";
  auto rt = fx.start(cfg);
  ASSERT_NE(rt, nullptr);
  auto ch = [&](const char* l) { return rt->image().read_channel(static_cast<uint32_t>(rt->image().find_channel(l))); };
  // The server starts with hr0 = 17; our write of 35 to hr1 is acknowledged by it.
  EXPECT_TRUE(eventually([&] { return ch("Level").quality == Quality::kGood && ch("Level").value == 17; }, 20));
  EXPECT_TRUE(eventually([&] { return rt->image().link(0).writes_acked.load() > 0; }, 20));
  rt->stop();
}

}  // namespace
}  // namespace rtplc::sched
