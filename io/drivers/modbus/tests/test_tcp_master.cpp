// The TCP slaves' event loop against fake slaves (tcp_master.h): polls on the
// clock's own multiples of the period, values and refusals, writes and their
// outcomes, a silent slave timed out, retried and reconnected while a healthy
// one on the same loop misses nothing, a late answer never taken for the next
// one, a killed slave's channels bad until it is back (reconnect counted, so
// the bridge resends its outputs), and the last queued writes sent on stop.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/tcp_master.h"
#include "tests/support/eventually.h"

namespace rtplc::modbus {
namespace {

using rtplc::testing::eventually;

struct Poll {
  uint32_t slave;
  int64_t due, answered;
};

SlaveConfig tcp_slave(const std::string& name, const FakeSlave& f, double poll_s, double timeout_s) {
  SlaveConfig sc;
  sc.name = name;
  sc.address = "127.0.0.1";
  sc.port = f.port();
  sc.poll_s = poll_s;
  sc.timeout_s = timeout_s;
  return sc;
}

ChannelMap map_of(const std::string& slave, const char* item) {
  ChannelMap m;
  m.slave = slave;
  m.item = *parse_address(item);
  return m;
}

// A slot's value as the bridge reads it: a load that met the writer
// mid-store is tried again.
template <typename T>
T load(link::SnapshotSlot<T>& slot) {
  T v{};
  for (int i = 0; i < 1000 && !slot.try_load(v); ++i) std::this_thread::yield();
  return v;
}
UnitStatus status_of(Exchange& x, uint32_t slave) { return load(x.status[slave]); }
ItemSample sample_of(Exchange& x, uint32_t read) { return load(x.samples[read]); }
WriteOutcome outcome_of(Exchange& x, uint32_t write) { return load(x.outcomes[write]); }

TEST(ModbusTcpMaster, polls_every_slave_on_the_grid_of_its_period) {
  FakeSlave a, b;
  ASSERT_TRUE(a.start().ok());
  ASSERT_TRUE(b.start().ok());
  constexpr int64_t kPeriod = 20'000'000;
  ModbusSettings s;
  s.slaves = {tcp_slave("a", a, 0.02, 0.5), tcp_slave("b", b, 0.02, 0.5)};
  s.reads = {map_of("a", "hr:0"), map_of("b", "hr:0")};
  Exchange x(s.reads.size(), 0, s.slaves.size());
  std::mutex mu;
  std::vector<Poll> polls;
  LineOptions opt;
  opt.wake_ns = kPeriod;
  opt.on_poll = [&](uint32_t slave, int64_t due, int64_t answered) {
    std::lock_guard lock(mu);
    polls.push_back({slave, due, answered});
  };
  TcpMaster m(s, {0, 1}, x, opt);
  ASSERT_TRUE(m.start().ok());
  auto count = [&](uint32_t slave) {
    std::lock_guard lock(mu);
    size_t n = 0;
    for (const Poll& p : polls) n += p.slave == slave;
    return n;
  };
  ASSERT_TRUE(eventually([&] { return count(0) >= 6 && count(1) >= 6; }));
  m.join();
  bool first[2] = {true, true};
  for (const Poll& p : polls) {
    EXPECT_GE(p.answered, p.due);
    if (first[p.slave]) {  // the first poll goes out at once, off the grid
      first[p.slave] = false;
      continue;
    }
    EXPECT_EQ(p.due % kPeriod, 0) << "slave " << p.slave << " due " << p.due;
  }
  for (uint32_t i = 0; i < 2; ++i) EXPECT_EQ(status_of(x, i).polls_completed, count(i));
  // One loop for both: it wakes about once per period and per answer, not per
  // slave and period on top (a loose bound: twice the polls plus slack).
  EXPECT_LE(m.wakeups(), 2 * polls.size() + 50);
}

class ModbusTcpMasterFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    FakeSlaveOptions o;
    o.delay_ns = 300'000'000;  // kMagicDelay: after two timeouts of 100 ms
    good_ = std::make_unique<FakeSlave>(o);
    bad_ = std::make_unique<FakeSlave>(o);
    ASSERT_TRUE(good_->start().ok());
    ASSERT_TRUE(bad_->start().ok());
    s_.slaves = {tcp_slave("good", *good_, 0.01, 0.1), tcp_slave("bad", *bad_, 0.01, 0.1)};
    s_.reads = {map_of("good", "hr:0"), map_of("bad", "hr:0")};
    s_.writes = {map_of("good", "hr:10"), map_of("good", "hr:65283"), map_of("bad", "coil:3")};
    good_->set(Table::kHoldingRegister, 0, 42);
    bad_->set(Table::kHoldingRegister, 0, 7);
  }
  void start() {
    x_ = std::make_unique<Exchange>(s_.reads.size(), s_.writes.size(), s_.slaves.size());
    opt_.wake_ns = 10'000'000;
    opt_.events = &events_;
    opt_.on_poll = [this](uint32_t slave, int64_t due, int64_t answered) {
      if (slave != 0) return;
      int64_t worst = worst_good_ns_.load();
      while (answered - due > worst && !worst_good_ns_.compare_exchange_weak(worst, answered - due)) {
      }
    };
    m_ = std::make_unique<TcpMaster>(s_, std::vector<uint32_t>{0, 1}, *x_, opt_);
    ASSERT_TRUE(m_->start().ok());
  }
  bool logged(const std::string& part) {
    io::LinkEvent e;
    while (events_.pop(e)) seen_.emplace_back(e.text);
    for (const std::string& t : seen_) {
      if (t.find(part) != std::string::npos) return true;
    }
    return false;
  }
  std::unique_ptr<FakeSlave> good_, bad_;
  ModbusSettings s_;
  std::unique_ptr<Exchange> x_;
  LineOptions opt_;
  io::LinkEventQueue events_{256};
  std::vector<std::string> seen_;
  std::atomic<int64_t> worst_good_ns_{0};  // the good slave's latest poll, from its due time
  std::unique_ptr<TcpMaster> m_;           // last: its loop stops before the rest goes
};

TEST_F(ModbusTcpMasterFaults, values_flow_and_writes_report_their_outcome) {
  start();
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 1).good && sample_of(*x_, 0).good; }));
  EXPECT_EQ(sample_of(*x_, 0).value, 42);
  EXPECT_EQ(sample_of(*x_, 1).value, 7);
  WriteJob w{0, 1, {513, 0}};
  ASSERT_TRUE(m_->push(w));
  WriteJob refused{1, 1, {1, 0}};  // hr:65283: the slave answers exception 3
  ASSERT_TRUE(m_->push(refused));
  WriteJob coil{2, 1, {1, 0}};
  ASSERT_TRUE(m_->push(coil));
  ASSERT_TRUE(eventually([&] { return outcome_of(*x_, 0).seq == 1 && outcome_of(*x_, 1).seq == 1 && outcome_of(*x_, 2).seq == 1; }));
  EXPECT_TRUE(outcome_of(*x_, 0).ok);
  EXPECT_EQ(good_->get(Table::kHoldingRegister, 10), 513);
  EXPECT_FALSE(outcome_of(*x_, 1).ok);
  EXPECT_EQ(outcome_of(*x_, 1).exception, 3);
  EXPECT_TRUE(outcome_of(*x_, 2).ok);
  EXPECT_EQ(bad_->get(Table::kCoil, 3), 1);
}

TEST_F(ModbusTcpMasterFaults, a_silent_slave_is_retried_and_reconnected_and_costs_the_other_no_poll) {
  start();
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 1).good && status_of(*x_, 0).polls_completed > 5; }));
  bad_->set_silent(true);
  ASSERT_TRUE(eventually([&] { return status_of(*x_, 1).reconnects >= 1; }));
  EXPECT_FALSE(sample_of(*x_, 1).good);
  EXPECT_EQ(sample_of(*x_, 1).value, 7);  // the last value kept, bad
  // Three polls, each a timeout and its retry, then the connection is dropped.
  EXPECT_GE(status_of(*x_, 1).timeouts, 6u);
  EXPECT_TRUE(logged("slave bad (127.0.0.1:")) << "no 'not answering' line";
  EXPECT_TRUE(logged("no answer to several polls"));
  // While the other one times out again and again, the good slave's polls are
  // never held for its timeout (100 ms): nobody waits on a silent socket. (A
  // loaded machine may delay the loop a little, never by a slave's timeout.)
  const uint64_t before = status_of(*x_, 0).polls_completed;
  worst_good_ns_ = 0;
  ASSERT_TRUE(eventually([&] { return status_of(*x_, 0).polls_completed >= before + 30; }));
  EXPECT_LT(worst_good_ns_.load(), 50'000'000);
  EXPECT_TRUE(sample_of(*x_, 0).good);
  bad_->set_silent(false);
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 1).good; }));
}

TEST_F(ModbusTcpMasterFaults, a_late_answer_is_never_taken_for_the_next_request) {
  // The slave's second block answers 300 ms late: after both attempts timed
  // out, while the first block's request is in flight.
  s_.reads.push_back(map_of("good", "hr:65500"));
  start();
  ASSERT_TRUE(eventually([&] { return status_of(*x_, 0).timeouts >= 4; }));
  for (int i = 0; i < 20; ++i) {
    good_->set(Table::kHoldingRegister, 0, static_cast<uint16_t>(100 + i));
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    const ItemSample smp = sample_of(*x_, 0);
    // The first block's own values only, never the late block's 0.
    if (smp.good) {
      EXPECT_TRUE(smp.value == 42 || (smp.value >= 100 && smp.value <= 100 + i)) << smp.value;
    }
    EXPECT_FALSE(sample_of(*x_, 2).good);
  }
}

TEST_F(ModbusTcpMasterFaults, a_killed_slave_is_bad_until_it_is_back_and_its_reconnect_is_counted) {
  start();
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 1).good; }));
  const uint64_t connects = status_of(*x_, 1).connects;
  bad_->kill();
  ASSERT_TRUE(eventually([&] { return !sample_of(*x_, 1).good; }));
  // Down, or trying to reconnect, and then never up while the slave is gone.
  // (The samples are stored as the loss is handled, the slave's status at the
  // end of that pass of the loop: a reader between the two sees it up still.)
  ASSERT_TRUE(eventually([&] { return status_of(*x_, 1).state != static_cast<uint8_t>(io::LinkState::kUp); }));
  for (int i = 0; i < 10; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_NE(status_of(*x_, 1).state, static_cast<uint8_t>(io::LinkState::kUp));
    EXPECT_FALSE(sample_of(*x_, 1).good);
  }
  EXPECT_TRUE(sample_of(*x_, 0).good);
  ASSERT_TRUE(bad_->restart().ok());
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 1).good; }));
  EXPECT_GT(status_of(*x_, 1).connects, connects);
  EXPECT_TRUE(logged("slave bad disconnected"));
  EXPECT_TRUE(logged("slave bad (127.0.0.1:" + std::to_string(bad_->port()) + " unit 1) connected"));
}

TEST_F(ModbusTcpMasterFaults, a_slave_that_is_not_there_at_start_is_said_once_and_joined_later) {
  bad_->kill();
  start();
  ASSERT_TRUE(eventually([&] { return logged("slave bad") && logged("unreachable at start"); }));
  EXPECT_TRUE(eventually([&] { return sample_of(*x_, 0).good; }));
  ASSERT_TRUE(bad_->restart().ok());
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 1).good; }));
}

TEST_F(ModbusTcpMasterFaults, the_writes_queued_last_go_out_on_stop) {
  start();
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 0).good; }));
  WriteJob w{0, 9, {4321, 0}};
  ASSERT_TRUE(m_->push(w));
  m_->join();
  EXPECT_EQ(good_->get(Table::kHoldingRegister, 10), 4321);
  EXPECT_EQ(outcome_of(*x_, 0).seq, 9u);
  EXPECT_TRUE(outcome_of(*x_, 0).ok);
}

TEST_F(ModbusTcpMasterFaults, answers_that_are_wrong_are_errors_and_the_link_recovers) {
  // A byte count two too long on one block, then a dropped connection on
  // another: both are bad, counted, and the slave's good block still reads.
  s_.reads.push_back(map_of("good", "hr:65502"));
  start();
  ASSERT_TRUE(eventually([&] { return status_of(*x_, 0).errors >= 2; }));
  EXPECT_FALSE(sample_of(*x_, 2).good);
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 0).good; }));
  EXPECT_EQ(sample_of(*x_, 0).value, 42);
}

TEST_F(ModbusTcpMasterFaults, a_slave_closing_the_connection_is_logged_as_such) {
  s_.reads.push_back(map_of("good", "hr:65501"));  // the fake closes instead of answering
  start();
  ASSERT_TRUE(eventually([&] { return logged("connection closed by the slave"); }));
  EXPECT_TRUE(eventually([&] { return status_of(*x_, 0).reconnects >= 1; }));
}

TEST_F(ModbusTcpMasterFaults, writes_every_cycle_do_not_starve_the_reads) {
  // A bridge that keeps the slave's write queue full: reads still go out on
  // their grid (writes and due polls alternate).
  start();
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 0).good; }));
  std::atomic<bool> done{false};
  std::atomic<uint64_t> pushed{0};
  std::thread bridge([&] {
    uint32_t seq = 1;
    while (!done.load()) {
      WriteJob w{0, seq, {static_cast<uint16_t>(seq), 0}};
      if (m_->push(w)) {
        ++seq;
        pushed.fetch_add(1);
      } else {
        std::this_thread::yield();
      }
    }
  });
  const UnitStatus before = status_of(*x_, 0);
  ASSERT_TRUE(eventually([&] { return pushed.load() > 2000; }));
  ASSERT_TRUE(eventually([&] { return status_of(*x_, 0).polls_completed >= before.polls_completed + 20; }));
  done = true;
  bridge.join();
  const UnitStatus after = status_of(*x_, 0);
  // Starved, the reads would stop and every slot count as missed; a loaded
  // machine may still make the loop miss one now and then.
  EXPECT_LT(after.polls_missed - before.polls_missed, after.polls_completed - before.polls_completed);
  good_->set(Table::kHoldingRegister, 0, 77);
  ASSERT_TRUE(eventually([&] { return sample_of(*x_, 0).value == 77; }));
}

}  // namespace
}  // namespace rtplc::modbus
