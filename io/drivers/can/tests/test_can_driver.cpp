// The can driver's bridge and I/O thread over the in-process fake bus: frames
// in -> channel values, a frame that stops -> bad with its last value, outputs
// -> frames with their ids, periods and bytes, nothing sent that the task
// cannot vouch for, bus-off and restart counted, the safe values sent at stop.
// Bridge cycles run at times the test chooses (cycle_now); the I/O thread is
// real, so a test waits for it by counts (never by durations).
#include <gtest/gtest.h>

#include <array>
#include <linux/can/error.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <thread>

#include "config/config.h"
#include "io/drivers/can/config.h"
#include "io/drivers/can/driver.h"
#include "io/drivers/can/fake_bus.h"
#include "kernel_rt/clock.h"
#include "tests/support/alloc_counter.h"
#include "tests/support/driver_test.h"

namespace rtplc::can {
namespace {

constexpr int64_t kMs = 1000000;

const char* kConfig =
    "tasks:\n  - {name: t, program: p.fbd}\n"
    "drivers:\n  - kind: can\n    name: epc\n    period: 5ms\n    interface: vcan0\n"
    "    receive:\n"
    "      - id: 0x181\n        timeout: 100ms\n        signals:\n"
    "          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, scale: 0.1}\n"
    "          - {channel: p0.d1.c1, byte: 2}\n"
    "    transmit:\n"
    "      - id: 0x201\n        period: 20ms\n        on_change: false\n        signals:\n"
    "          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, scale: 0.1}\n"
    "          - {channel: p0.d1.c1, byte: 2}\n"
    "      - id: 0x18FF0001\n        period: 50ms\n        length: 4\n        signals:\n"
    "          - {channel: p0.d2.c0, byte: 0, length: 4, type: float, order: big}\n";

// A process image with one task region (the 3 outputs) and the driver's region
// (2 inputs, then 3 delivery entries), as the runtime would lay it out.
struct Rig {
  config::LoadResult cfg;
  io::ProcessImage image;
  FakeBus bus;
  io::LinkEventQueue events;
  std::unique_ptr<CanDriver> driver;

  // `on_bad`: the three outputs' policies (config::OnBad), safe values 0.
  explicit Rig(const char* yaml = kConfig, std::array<uint8_t, 3> on_bad = {0, 0, 0}) {
    cfg = config::parse_config(yaml, "c.yaml", "", config::LoadOptions{false});
    EXPECT_TRUE(cfg.ok()) << cfg.render();
    image = test::driver_image("candrv", "epc", 2, 3);
    io::DriverSetup setup = test::driver_setup(cfg.config->drivers[0], image, events, 2, 3, 5 * kMs);
    for (size_t j = 0; j < 3; ++j) setup.consumes[j].on_bad = static_cast<config::OnBad>(on_bad[j]);
    driver = std::make_unique<CanDriver>(setup, bus.transport());
  }

  void outputs(double a, double b, double c, Quality q = Quality::kGood) {
    test::put_task_outputs(image, {a, b, c}, q);
  }
  // One task write with a quality per output.
  void outputs(std::array<double, 3> v, std::array<Quality, 3> q) {
    const uint32_t k = image.begin_write(0);
    for (uint32_t i = 0; i < 3; ++i) image.put(0, k, i, v[i], q[i], 1);
    image.end_write(0, k, 1, 0);
  }
  std::pair<double, Quality> entry(uint32_t idx) { return test::driver_entry(image, idx); }
  // Waits (by count; the bound only keeps a broken build from hanging) until
  // the fake bus saw `n` frames from the driver.
  bool wait_sent(size_t n) {
    for (int i = 0; i < 20000 && bus.sent_count() < n; ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
    return bus.sent_count() >= n;
  }
  bool wait_received(uint64_t n) {
    for (int i = 0; i < 20000 && driver->counters().frames_rx < n; ++i) {
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    return driver->counters().frames_rx >= n;
  }
  bool logged(const std::string& part) {
    io::LinkEvent e;
    bool found = false;
    while (events.pop(e)) found = found || std::string(e.text).find(part) != std::string::npos;
    return found;
  }
};

Frame frame(uint32_t id, std::initializer_list<uint8_t> bytes) {
  Frame f;
  f.id = id;
  f.len = static_cast<uint8_t>(bytes.size());
  uint8_t i = 0;
  for (uint8_t b : bytes) f.data[i++] = b;
  return f;
}

TEST(CanDriver, says_which_values_a_transmit_signal_cannot_carry) {
  Rig r;
  // Output 0: signed 2 bytes at scale 0.1 (-3276.8 .. 3276.7).
  EXPECT_TRUE(r.driver->can_send(0, 100.5).ok());
  Result<void> no = r.driver->can_send(0, 5000);
  ASSERT_FALSE(no.ok());
  EXPECT_NE(no.error().find("p0.d1.c0 in frame 201 cannot carry 5000"), std::string::npos) << no.error();
  EXPECT_NE(no.error().find("signed 2-byte"), std::string::npos) << no.error();
  // Output 1: one unsigned byte.
  EXPECT_TRUE(r.driver->can_send(1, 255).ok());
  EXPECT_FALSE(r.driver->can_send(1, 256).ok());
  EXPECT_FALSE(r.driver->can_send(1, -1).ok());
  // Output 2: a 4-byte float: beyond float's range is refused.
  EXPECT_TRUE(r.driver->can_send(2, 1e30).ok());
  EXPECT_FALSE(r.driver->can_send(2, 1e300).ok());
}

TEST(CanDriver, filters_the_socket_to_the_receive_ids) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  const auto f = r.bus.last_filters();
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 0x181u);
  EXPECT_FALSE(f[0].extended);
}

TEST(CanDriver, fails_clearly_when_the_interface_is_missing) {
  std::string yaml = kConfig;
  yaml.replace(yaml.find("vcan0"), 5, "missing");
  Rig r(yaml.c_str());
  auto s = r.driver->start_io();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("can driver 'epc': CAN interface 'missing' does not exist"), std::string::npos) << s.error();
}

TEST(CanDriver, publishes_received_signals_that_turn_stale_after_the_timeout) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.driver->cycle_now(t0);
  EXPECT_EQ(r.entry(0).second, Quality::kBad);  // nothing received yet: never good
  r.bus.inject(frame(0x181, {0x9C, 0xFF, 7}));  // -100 * 0.1, 7
  r.bus.inject(frame(0x182, {1, 2, 3}));        // not mapped: the filter drops it
  ASSERT_TRUE(r.wait_received(1));
  const int64_t t1 = kernel_rt::monotonic_now_ns();
  r.driver->cycle_now(t1);
  EXPECT_DOUBLE_EQ(r.entry(0).first, -10.0);
  EXPECT_EQ(r.entry(0).second, Quality::kGood);
  EXPECT_EQ(r.entry(1).first, 7.0);
  EXPECT_EQ(r.entry(1).second, Quality::kGood);
  // The drive goes quiet: after the frame's timeout (its channels' max age)
  // every reader judges them stale, with their last values and the frame's time.
  const int64_t later = t1 + 101 * kMs;
  r.driver->cycle_now(later);
  EXPECT_DOUBLE_EQ(r.entry(0).first, -10.0);
  double v = 0;
  Quality q = Quality::kBad;
  int64_t at = 0;
  const uint32_t idx = 0;
  ASSERT_TRUE(r.image.read_values(1, &idx, 1, &v, 8, nullptr, &q, &at));
  EXPECT_EQ(io::judge_quality(q, v, at, later, 100 * kMs), Quality::kStale);
  EXPECT_EQ(io::judge_quality(q, v, at, t1, 100 * kMs), Quality::kGood);
  EXPECT_EQ(r.driver->rx_timeouts(), 1u);
  EXPECT_TRUE(r.logged("frame 181 not received for 100 ms"));
  EXPECT_EQ(r.driver->counters().frames_rx, 1u);
}

TEST(CanDriver, refuses_a_frame_shorter_than_its_signals) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.bus.inject(frame(0x181, {1, 2}));  // byte 2 missing
  r.bus.inject(frame(0x181, {1, 0, 3}));
  ASSERT_TRUE(r.wait_received(1));
  EXPECT_EQ(r.driver->counters().bad_frames, 1u);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(1).first, 3.0);
  EXPECT_TRUE(r.logged("frame 181 has 2 data bytes, its signals need 3"));
}

TEST(CanDriver, sends_each_frame_at_its_own_period_with_its_bytes) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(-1.5, 200, 2.5);
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  for (int i = 0; i <= 20; ++i) r.driver->cycle_now(t0 + i * 5 * kMs);  // 0..100 ms
  // 0x201 every 20 ms: 0, 20, 40, 60, 80, 100; 0x18FF0001 every 50 ms: 0, 50, 100.
  ASSERT_TRUE(r.wait_sent(9));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // nothing more arrives
  const auto sent = r.bus.sent();
  ASSERT_EQ(sent.size(), 9u);
  int a = 0, b = 0;
  for (const Frame& f : sent) {
    if (f.id == 0x201) {
      ++a;
      EXPECT_FALSE(f.extended);
      ASSERT_EQ(f.len, 8);
      EXPECT_EQ(f.data[0], 0xF1);  // -15 little-endian
      EXPECT_EQ(f.data[1], 0xFF);
      EXPECT_EQ(f.data[2], 200);
    } else {
      ++b;
      EXPECT_EQ(f.id, 0x18FF0001u);
      EXPECT_TRUE(f.extended);
      ASSERT_EQ(f.len, 4);
      EXPECT_EQ(f.data[0], 0x40);  // 2.5f big-endian: 40 20 00 00
      EXPECT_EQ(f.data[1], 0x20);
      EXPECT_EQ(f.data[2], 0x00);
    }
  }
  EXPECT_EQ(a, 6);
  EXPECT_EQ(b, 3);
  r.driver->cycle_now(t0 + 101 * kMs);
  EXPECT_EQ(r.entry(2).second, Quality::kGood);  // delivered
  EXPECT_DOUBLE_EQ(r.entry(2).first, -1.5);
}

TEST(CanDriver, sends_a_changed_value_at_once_when_on_change) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(0, 0, 1);
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.driver->cycle_now(t0);  // both frames once
  ASSERT_TRUE(r.wait_sent(2));
  r.outputs(0, 0, 2);       // 0x18FF0001 has on_change (the default)
  r.driver->cycle_now(t0 + 5 * kMs);
  r.outputs(0, 1, 2);       // 0x201 has not: waits for its period
  r.driver->cycle_now(t0 + 10 * kMs);
  ASSERT_TRUE(r.wait_sent(3));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto sent = r.bus.sent();
  ASSERT_EQ(sent.size(), 3u);
  EXPECT_EQ(sent[2].id, 0x18FF0001u);
  EXPECT_EQ(sent[2].data[0], 0x40);  // 2.0f
}

TEST(CanDriver, never_sends_a_frame_with_an_output_it_cannot_vouch_for) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(1, 2, 3, Quality::kBad);
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  for (int i = 0; i < 10; ++i) r.driver->cycle_now(t0 + i * 20 * kMs);
  r.outputs(1, 300, 3);  // 300 does not fit the unsigned byte of 0x201
  for (int i = 10; i < 20; ++i) r.driver->cycle_now(t0 + i * 20 * kMs);
  ASSERT_TRUE(r.wait_sent(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  for (const Frame& f : r.bus.sent()) EXPECT_NE(f.id, 0x201u);
  EXPECT_EQ(r.entry(2).second, Quality::kBad);  // 0x201's outputs: not delivered
  EXPECT_EQ(r.entry(4).second, Quality::kGood);
  EXPECT_EQ(r.driver->rejected(), 1u);
  EXPECT_TRUE(r.logged("p0.d1.c1 = 300 does not fit its signal in frame 201"));
}

// examples/drive.fbd with the drive silent: Torque (from the stale speed) is
// not good, Enable (a good 0) is. Hold keeps Torque's last bytes in the frame
// and sends Enable 0 at once; a frame whose every signal is held keeps its
// period with its last bytes (the peer keeps what it has).
TEST(CanDriver, holds_a_signal_it_cannot_vouch_for_at_its_last_bytes_and_sends_the_others) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.outputs({-1.5, 1, 2.5}, {Quality::kGood, Quality::kGood, Quality::kGood});
  r.driver->cycle_now(t0);
  ASSERT_TRUE(r.wait_sent(2));
  r.outputs({-9, 0, 2.5}, {Quality::kStale, Quality::kGood, Quality::kBad});
  r.driver->cycle_now(t0 + 20 * kMs);
  ASSERT_TRUE(r.wait_sent(3));
  r.driver->cycle_now(t0 + 25 * kMs);
  const auto sent = r.bus.sent();
  const Frame& f = sent.back();
  ASSERT_EQ(f.id, 0x201u);
  EXPECT_EQ(f.data[0], 0xF1) << "Torque keeps its last bytes (-1.5)";
  EXPECT_EQ(f.data[2], 0) << "Enable 0 is sent";
  EXPECT_EQ(r.entry(2).second, Quality::kBad) << "the held signal is not delivered";
  EXPECT_EQ(r.entry(3).second, Quality::kGood);
  // Every signal held: 0x201 keeps its period with the bytes sent last.
  r.outputs({-9, 1, 2.5}, {Quality::kStale, Quality::kStale, Quality::kBad});
  const size_t before = r.bus.sent_count();
  for (int i = 2; i < 6; ++i) r.driver->cycle_now(t0 + i * 20 * kMs);  // 40..100 ms: 4 periods
  ASSERT_TRUE(r.wait_sent(before + 4));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto all = r.bus.sent();
  size_t n201 = 0;
  Frame g;
  for (size_t i = before; i < all.size(); ++i) {
    if (all[i].id == 0x201u) ++n201, g = all[i];
  }
  EXPECT_EQ(n201, 4u);
  EXPECT_EQ(g.data[0], 0xF1);
  EXPECT_EQ(g.data[2], 0) << "Enable keeps the 0 sent last";
}

TEST(CanDriver, sends_the_safe_value_or_the_value_anyway_by_policy) {
  Rig r(kConfig, {1, 2, 0});  // Torque safe (0), Enable send
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs({-1.5, 1, 2.5}, {Quality::kStale, Quality::kBad, Quality::kGood});
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.driver->cycle_now(t0);
  ASSERT_TRUE(r.wait_sent(2));
  for (const Frame& f : r.bus.sent()) {
    if (f.id != 0x201u) continue;
    EXPECT_EQ(f.data[0], 0);
    EXPECT_EQ(f.data[1], 0);
    EXPECT_EQ(f.data[2], 1);
  }
}

TEST(CanDriver, counts_bus_off_and_restart_and_reports_the_bus_down_meanwhile) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(0, 0, 0);
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.driver->cycle_now(t0);
  ASSERT_TRUE(r.wait_sent(2));
  r.bus.inject_error(CAN_ERR_BUSOFF);
  for (int i = 0; i < 20000 && r.driver->counters().bus_offs == 0; ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
  r.driver->cycle_now(t0 + 5 * kMs);
  EXPECT_EQ(r.entry(2).second, Quality::kBad);
  EXPECT_TRUE(r.logged("CAN controller: bus-off"));
  r.bus.inject_error(CAN_ERR_RESTARTED);
  for (int i = 0; i < 20000 && r.driver->counters().restarts == 0; ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
  r.driver->cycle_now(t0 + 200 * kMs);
  const BusCounters c = r.driver->counters();
  EXPECT_EQ(c.bus_offs, 1u);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(c.error_frames, 2u);
  EXPECT_EQ(c.up, 1);
  const io::LinkStatus& ls = r.image.link(0);
  EXPECT_EQ(ls.polls_missed.load(), 1u);  // bus-offs
  EXPECT_EQ(ls.reconnects.load(), 1u);    // restarts
  EXPECT_EQ(ls.errors.load(), 2u);
  EXPECT_EQ(ls.state.load(), static_cast<uint8_t>(io::LinkState::kUp));
}

TEST(CanDriver, marks_outputs_undelivered_while_sends_fail) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.bus.refuse_sends(true);
  r.outputs(0, 0, 0);
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.driver->cycle_now(t0);
  for (int i = 0; i < 20000 && r.driver->counters().tx_failed < 2; ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
  r.driver->cycle_now(t0 + 5 * kMs);
  EXPECT_EQ(r.entry(2).second, Quality::kBad);
  EXPECT_EQ(r.entry(4).second, Quality::kBad);
  EXPECT_TRUE(r.logged("failed: Network is down"));
  r.bus.refuse_sends(false);
  r.outputs(0, 0, 1);
  r.driver->cycle_now(t0 + 60 * kMs);
  ASSERT_TRUE(r.wait_sent(2));
  for (int i = 0; i < 20000 && r.driver->counters().frames_tx < 2; ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
  r.driver->cycle_now(t0 + 65 * kMs);
  EXPECT_EQ(r.entry(2).second, Quality::kGood);
  EXPECT_EQ(r.entry(4).second, Quality::kGood);
}

TEST(CanDriver, sends_the_safe_values_once_more_at_stop) {
  std::string yaml = kConfig;
  yaml.replace(yaml.find("period: 20ms"), 12, "period: 3600");
  yaml.replace(yaml.find("period: 50ms\n        length: 4"), 12, "period: 3600");
  yaml.replace(yaml.find("length: 4\n"), 10, "length: 4\n        on_change: false\n");
  Rig r(yaml.c_str());
  r.outputs(5, 6, 7);
  ASSERT_TRUE(r.driver->start(kernel_rt::monotonic_now_ns()).ok());
  ASSERT_TRUE(r.wait_sent(2));  // each frame once at start, then not for an hour
  r.outputs(0, 0, 0);           // what the stopped task leaves: its safe values
  r.driver->request_stop();
  r.driver->join();
  const auto sent = r.bus.sent();
  ASSERT_EQ(sent.size(), 4u);
  EXPECT_EQ(sent[0].data[2], 6);
  EXPECT_EQ(sent[2].id, 0x201u);
  EXPECT_EQ(sent[2].data[0], 0);
  EXPECT_EQ(sent[2].data[2], 0);
  EXPECT_EQ(sent[3].id, 0x18FF0001u);
  EXPECT_EQ(sent[3].data[0], 0);
  EXPECT_EQ(r.bus.ports_open(), 0);
}

// The fake's bounded receive queue (what the benchmark's loss counts rest on):
// a port holds at most the limit, the rest is dropped and counted, in order.
TEST(FakeBus, drops_frames_beyond_a_ports_receive_limit_and_counts_them) {
  FakeBus bus;
  bus.limit_rx(2);
  const IdFilter only181[] = {{0x181, false, kMaxExtendedId}};
  auto port = Port::open(bus.transport(), "vcan0", only181, false);
  ASSERT_TRUE(port.ok()) << port.error();
  for (uint8_t i = 1; i <= 3; ++i) bus.inject(frame(0x181, {i}));
  bus.inject(frame(0x182, {9}));  // filtered out: neither queued nor dropped
  EXPECT_EQ(bus.rx_dropped(), 1u);
  Frame f;
  int err = 0;
  ASSERT_EQ(port->recv(f, kMs, &err), RecvResult::kFrame);
  EXPECT_EQ(f.data[0], 1);
  ASSERT_EQ(port->recv(f, kMs, &err), RecvResult::kFrame);
  EXPECT_EQ(f.data[0], 2);
  EXPECT_EQ(port->recv(f, kMs, &err), RecvResult::kTimeout);
  bus.inject(frame(0x181, {4}));  // room again
  ASSERT_EQ(port->recv(f, kMs, &err), RecvResult::kFrame);
  EXPECT_EQ(f.data[0], 4);
  EXPECT_EQ(bus.rx_dropped(), 1u);
}

// Real-time hygiene (kernel_rt/cycle_scope.h): the bridge's cycles allocate
// nothing through every fault they log: a frame timeout and its return, held
// outputs, a value that does not fit, the bus off and back.
TEST(CanDriver, its_cycles_allocate_nothing_whatever_the_faults) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  r.outputs(1, 2, 3);
  r.driver->cycle_now(t0);  // the first cycle may size what it keeps
  ASSERT_TRUE(r.wait_sent(2));
  testing::AllocationCounter count;
  r.bus.inject(frame(0x181, {0x9C, 0xFF, 7}));
  ASSERT_TRUE(r.wait_received(1));
  int64_t t = t0;
  for (int i = 1; i < 60; ++i) {
    t = t0 + i * 5 * kMs;
    if (i == 10) r.outputs(1, 300, 3);                    // does not fit: refused, logged
    if (i == 20) r.outputs(1, 2, 3, Quality::kStale);     // held
    if (i == 30) r.bus.inject_error(CAN_ERR_BUSOFF);
    if (i == 35) r.bus.inject_error(CAN_ERR_RESTARTED);
    if (i == 40) r.bus.inject(frame(0x181, {1, 0, 1}));  // received again after the timeout
    r.driver->cycle_now(t);
  }
  EXPECT_EQ(count.in_cycles(), 0u) << "first allocation on thread '" << count.first_thread() << "'";
  EXPECT_GE(r.driver->rx_timeouts(), 1u);
  EXPECT_EQ(r.driver->rejected(), 1u);
}

}  // namespace
}  // namespace rtplc::can
