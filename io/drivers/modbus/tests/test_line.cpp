// A TCP line against the fake slave (line.h): its polls sit on the clock's own
// multiples of the period, the grid every line of that period shares (so a
// hundred lines wake together once per period), and the measurement hook sees
// exactly the polls the line counts as completed.
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/line.h"

namespace rtplc::modbus {
namespace {

struct Poll {
  uint32_t slave;
  int64_t due, answered;
};

TEST(ModbusLine, polls_on_the_grid_every_line_of_one_period_shares) {
  FakeSlave a, b;
  ASSERT_TRUE(a.start().ok());
  ASSERT_TRUE(b.start().ok());
  constexpr int64_t kPeriod = 20'000'000;
  ModbusSettings s;
  for (FakeSlave* f : {&a, &b}) {
    SlaveConfig sc;
    sc.name = f == &a ? "a" : "b";
    sc.address = "127.0.0.1";
    sc.port = f->port();
    sc.poll_s = 0.02;
    sc.timeout_s = 0.5;
    s.slaves.push_back(sc);
    ChannelMap m;
    m.slave = sc.name;
    m.item = *parse_address("hr:0");
    s.reads.push_back(m);
  }
  Exchange x(s.reads.size(), 0, s.slaves.size());
  std::mutex mu;
  std::vector<Poll> polls;
  LineOptions opt;
  opt.wake_ns = kPeriod;
  opt.on_poll = [&](uint32_t slave, int64_t due, int64_t answered) {
    std::lock_guard lock(mu);
    polls.push_back({slave, due, answered});
  };
  Line la(s, std::vector<uint32_t>{0}, x, opt), lb(s, std::vector<uint32_t>{1}, x, opt);
  ASSERT_TRUE(la.start().ok());
  ASSERT_TRUE(lb.start().ok());
  auto count = [&](uint32_t slave) {
    std::lock_guard lock(mu);
    size_t n = 0;
    for (const Poll& p : polls) n += p.slave == slave;
    return n;
  };
  for (int i = 0; i < 1000 && (count(0) < 6 || count(1) < 6); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  la.join();
  lb.join();
  ASSERT_GE(count(0), 6u);
  ASSERT_GE(count(1), 6u);
  bool first[2] = {true, true};
  for (const Poll& p : polls) {
    EXPECT_GE(p.answered, p.due);
    if (first[p.slave]) {  // the first poll goes out at once, off the grid
      first[p.slave] = false;
      continue;
    }
    EXPECT_EQ(p.due % kPeriod, 0) << "slave " << p.slave << " due " << p.due;
  }
  for (uint32_t i = 0; i < 2; ++i) {
    UnitStatus st;
    ASSERT_TRUE(x.status[i].try_load(st));
    EXPECT_EQ(st.polls_completed, count(i));
  }
}

}  // namespace
}  // namespace rtplc::modbus
