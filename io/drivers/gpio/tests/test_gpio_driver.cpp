// The gpio driver's bridge and edge-event thread over the in-process fake
// chips: levels in (active-low, debounced), every edge of a burst counted
// between two cycles, bounces ignored by kernel timestamp, outputs driven only
// when they change and to their safe level when the task cannot vouch for
// them, the tasks' safe values driven at stop, and start errors that name the
// entry. Bridge cycles run when the test says (cycle_now); the I/O thread is
// real, so a test waits for it by counts (never by durations).
#include <gtest/gtest.h>

#include <array>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <functional>
#include <memory>
#include <thread>

#include "config/config.h"
#include "io/drivers/gpio/config.h"
#include "io/drivers/gpio/driver.h"
#include "io/drivers/gpio/fake_chip.h"
#include "kernel_rt/clock.h"
#include "tests/support/alloc_counter.h"
#include "tests/support/driver_test.h"

namespace rtplc::gpio {
namespace {

constexpr int64_t kMs = 1000000;

// Region: [0] ddi line 0, [1] ddi BTN (line 1, active-low, debounced),
// [2] dpi line 2 rising, [3] dpi line 3 both edges debounced; then the
// deliveries of [4] ddo line 4 and [5] ddo line 5 (active-low, safe 1).
const char* kConfig =
    "tasks:\n  - {name: t, program: p.fbd}\n"
    "drivers:\n  - kind: gpio\n    name: dio\n    period: 1ms\n    chip: gpiochip0\n"
    "    inputs:\n"
    "      - {channel: p0.d0.c0, line: 0}\n"
    "      - {channel: p0.d0.c1, line: BTN, active_low: true, bias: pull-up, debounce: 100ms}\n"
    "    counters:\n"
    "      - {channel: p0.d0.c0, line: 2}\n"
    "      - {channel: p0.d0.c1, line: 3, edge: both, debounce: 1ms}\n"
    "    outputs:\n"
    "      - {channel: p0.d0.c0, line: 4}\n"
    "      - {channel: p0.d0.c1, line: LAMP, active_low: true, safe: 1}\n";

struct Rig {
  config::LoadResult cfg;
  io::ProcessImage image;
  FakeChips chips;
  io::LinkEventQueue events;
  std::unique_ptr<GpioDriver> driver;

  // `on_bad`/`safe`: the two outputs' policies (config::OnBad) and safe values.
  explicit Rig(const char* yaml = kConfig, std::array<uint8_t, 2> on_bad = {0, 0},
               std::array<double, 2> safe = {0, 0}) {
    chips.add_chip("gpiochip0", "gpio-fake.0", 8, {"", "BTN", "", "", "", "LAMP"});
    cfg = config::parse_config(yaml, "c.yaml", "", config::LoadOptions{false});
    EXPECT_TRUE(cfg.ok()) << cfg.render();
    image = test::driver_image("gpiodrv", "dio", 4, 2);
    io::DriverSetup setup = test::driver_setup(cfg.config->drivers[0], image, events, 4, 2, 1 * kMs);
    for (size_t j = 0; j < 2; ++j) {
      setup.consumes[j].on_bad = static_cast<config::OnBad>(on_bad[j]);
      setup.consumes[j].safe_value = safe[j];
    }
    driver = std::make_unique<GpioDriver>(setup, chips.ops());
  }

  void outputs(double a, double b, Quality q = Quality::kGood) { test::put_task_outputs(image, {a, b}, q); }
  std::pair<double, Quality> entry(uint32_t idx) { return test::driver_entry(image, idx); }
  // Waits (by condition; the bound only keeps a broken build from hanging).
  static bool wait_for(const std::function<bool()>& done) {
    for (int i = 0; i < 20000 && !done(); ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
    return done();
  }
  bool logged(const std::string& part) {
    io::LinkEvent e;
    bool found = false;
    while (events.pop(e)) found = found || std::string(e.text).find(part) != std::string::npos;
    return found;
  }
};

TEST(GpioDriver, requests_its_lines_by_offset_and_by_name_and_releases_them) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  for (unsigned l = 0; l < 6; ++l) EXPECT_TRUE(r.chips.requested("gpiochip0", l)) << l;
  EXPECT_FALSE(r.chips.requested("gpiochip0", 6));
  EXPECT_EQ(r.chips.level("gpiochip0", 5), 0);  // LAMP: safe 1, active-low -> driven low from the start
  r.driver.reset();
  for (unsigned l = 0; l < 6; ++l) EXPECT_FALSE(r.chips.requested("gpiochip0", l)) << l;
}

TEST(GpioDriver, reads_input_levels_every_cycle) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(0), std::make_pair(0.0, Quality::kGood));
  EXPECT_EQ(r.entry(1), std::make_pair(1.0, Quality::kGood));  // BTN active-low: low reads 1
  r.chips.pull("gpiochip0", 0, 1, kernel_rt::monotonic_now_ns());
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(0), std::make_pair(1.0, Quality::kGood));
}

TEST(GpioDriver, a_failing_read_is_bad_and_logged_once) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.chips.fail_io(EIO);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(0).second, Quality::kBad);
  EXPECT_TRUE(r.logged("reading gpiochip0 line 0 failed"));
  r.chips.fail_io(0);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(0).second, Quality::kGood);
  EXPECT_TRUE(r.logged("works again"));
}

TEST(GpioDriver, debounced_input_takes_a_level_only_once_it_held) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  // A bounce: high and back within microseconds -> the level never changes.
  const int64_t t = kernel_rt::monotonic_now_ns();
  r.chips.pull("gpiochip0", 1, 1, t);
  r.chips.pull("gpiochip0", 1, 0, t + 10000);
  ASSERT_TRUE(Rig::wait_for([&] { return r.driver->edges_of(1).ignored >= 1; }));
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(1), std::make_pair(1.0, Quality::kGood));
  // Pressed for good: the new level once it held 100 ms.
  r.chips.pull("gpiochip0", 1, 1, kernel_rt::monotonic_now_ns());
  ASSERT_TRUE(Rig::wait_for([&] { return r.driver->edges_of(1).level == 0; }));
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(1), std::make_pair(0.0, Quality::kGood));
}

TEST(GpioDriver, counts_every_edge_of_a_burst_between_two_cycles) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(2), std::make_pair(0.0, Quality::kGood));
  int64_t t = kernel_rt::monotonic_now_ns();
  for (int i = 0; i < 1000; ++i) {  // 1000 pulses 2 us apart: far faster than any task
    r.chips.pull("gpiochip0", 2, 1, t += 1000);
    r.chips.pull("gpiochip0", 2, 0, t += 1000);
  }
  ASSERT_TRUE(Rig::wait_for([&] { return r.driver->edges_of(2).count >= 1000; }));
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(2), std::make_pair(1000.0, Quality::kGood));
  EXPECT_EQ(r.driver->edges_of(2).count, 1000u);
  EXPECT_EQ(r.driver->edges_of(2).ignored, 0u);  // falling edges are not even queued
}

TEST(GpioDriver, ignores_edges_inside_the_debounce_time_by_kernel_timestamp) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  int64_t t = kernel_rt::monotonic_now_ns();
  int level = 0;
  for (int burst = 0; burst < 3; ++burst) {
    for (int i = 0; i < 5; ++i) r.chips.pull("gpiochip0", 3, level ^= 1, t + i * 100000);  // 5 edges in 0.4 ms
    t += 10 * kMs;
  }
  ASSERT_TRUE(Rig::wait_for([&] { return r.driver->edges_of(3).count + r.driver->edges_of(3).ignored >= 15; }));
  EXPECT_EQ(r.driver->edges_of(3).count, 3u);  // one per burst
  EXPECT_EQ(r.driver->edges_of(3).ignored, 12u);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(3), std::make_pair(3.0, Quality::kGood));
}

TEST(GpioDriver, drives_outputs_only_when_they_change) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(1, 1);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.chips.level("gpiochip0", 4), 1);
  EXPECT_EQ(r.chips.level("gpiochip0", 5), 0);  // active-low
  EXPECT_EQ(r.entry(4), std::make_pair(1.0, Quality::kGood));
  EXPECT_EQ(r.entry(5), std::make_pair(1.0, Quality::kGood));
  const uint64_t sets = r.chips.sets();
  for (int i = 0; i < 10; ++i) r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.chips.sets(), sets);
  r.outputs(0, 0);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.chips.level("gpiochip0", 4), 0);
  EXPECT_EQ(r.chips.level("gpiochip0", 5), 1);
  EXPECT_EQ(r.chips.sets(), sets + 2);
}

// An output the task cannot vouch for (computed from a bad input) goes by
// its on_bad policy: hold keeps the level driven last, safe drives the task's
// safe value, send drives the computed value anyway.
TEST(GpioDriver, acts_on_an_output_the_task_cannot_vouch_for_by_its_policy) {
  {
    Rig r;  // hold, the default
    ASSERT_TRUE(r.driver->start_io().ok());
    r.outputs(1, 0);
    r.driver->cycle_now(kernel_rt::monotonic_now_ns());
    EXPECT_EQ(r.chips.level("gpiochip0", 4), 1);
    EXPECT_EQ(r.chips.level("gpiochip0", 5), 1);  // active-low
    r.outputs(0, 1, Quality::kBad);
    r.driver->cycle_now(kernel_rt::monotonic_now_ns());
    EXPECT_EQ(r.chips.level("gpiochip0", 4), 1) << "held";
    EXPECT_EQ(r.chips.level("gpiochip0", 5), 1) << "held";
    EXPECT_EQ(r.entry(4), std::make_pair(1.0, Quality::kBad)) << "what the line has, not vouched for";
  }
  {
    Rig r(kConfig, {1, 2}, {0, 0});  // first safe (0), second send
    ASSERT_TRUE(r.driver->start_io().ok());
    r.outputs(1, 0);
    r.driver->cycle_now(kernel_rt::monotonic_now_ns());
    r.outputs(1, 1, Quality::kStale);
    r.driver->cycle_now(kernel_rt::monotonic_now_ns());
    EXPECT_EQ(r.chips.level("gpiochip0", 4), 0) << "its safe value";
    EXPECT_EQ(r.chips.level("gpiochip0", 5), 0) << "the computed 1, active-low";
    EXPECT_EQ(r.entry(4).first, 0.0);
  }
}

// A snapshot the bridge could not read consistently (here: the ring as a reader
// meets it while the task laps it) is no reason to move an output: the line
// keeps the level driven last instead of jumping to its safe level.
TEST(GpioDriver, keeps_the_level_it_drove_when_a_cycle_cannot_read_the_outputs) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  for (int i = 0; i < 5; ++i) r.outputs(1, 1);  // publications 1..5 of the task region
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  ASSERT_EQ(r.chips.level("gpiochip0", 4), 1);
  ASSERT_EQ(r.chips.level("gpiochip0", 5), 0);  // active-low
  // `published` as a delayed reader sees it while slot 1 already holds a later lap.
  r.image.ring(0).published.store(1);
  const uint64_t sets = r.chips.sets();
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.chips.level("gpiochip0", 4), 1) << "driven to its safe level on a read miss";
  EXPECT_EQ(r.chips.level("gpiochip0", 5), 0);
  EXPECT_EQ(r.chips.sets(), sets);
  EXPECT_EQ(r.entry(4), std::make_pair(1.0, Quality::kGood));
  // The next consistent snapshot applies as usual.
  r.image.ring(0).published.store(5);
  r.outputs(0, 1);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.chips.level("gpiochip0", 4), 0);
}

TEST(GpioDriver, a_failing_set_is_bad_and_retried) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.chips.fail_io(EIO);
  r.outputs(1, 0);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.entry(4).second, Quality::kBad);
  EXPECT_TRUE(r.logged("driving gpiochip0 line 4 failed"));
  r.chips.fail_io(0);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  EXPECT_EQ(r.chips.level("gpiochip0", 4), 1);
  EXPECT_EQ(r.entry(4), std::make_pair(1.0, Quality::kGood));
}

TEST(GpioDriver, drives_the_tasks_safe_values_at_stop) {
  Rig r;
  r.outputs(1, 1);
  ASSERT_TRUE(r.driver->start(kernel_rt::monotonic_now_ns()).ok());
  ASSERT_TRUE(Rig::wait_for([&] { return r.chips.level("gpiochip0", 4) == 1; }));
  r.outputs(0, 1);  // what the stopped task leaves: its safe values
  r.driver->request_stop();
  r.driver->join();
  EXPECT_EQ(r.chips.level("gpiochip0", 4), 0);
  EXPECT_EQ(r.chips.level("gpiochip0", 5), 0);  // 1, active-low
  EXPECT_FALSE(r.chips.requested("gpiochip0", 4));
}

TEST(GpioDriver, start_errors_name_the_entry) {
  std::string yaml = kConfig;
  yaml.replace(yaml.find("line: BTN"), 9, "line: NOPE");
  Rig r(yaml.c_str());
  auto s = r.driver->start_io();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("gpio driver 'dio': inputs entry p0.d0.c1 at line 10:35: chip gpiochip0 has no line "
                           "named 'NOPE'"),
            std::string::npos)
      << s.error();
  EXPECT_FALSE(r.chips.requested("gpiochip0", 0));  // what was requested before is released

  yaml = kConfig;
  yaml.replace(yaml.find("line: 4"), 7, "line: 9");
  Rig r2(yaml.c_str());
  s = r2.driver->start_io();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("chip gpiochip0 has 8 lines (0..7), not line 9"), std::string::npos) << s.error();

  yaml = kConfig;
  yaml.replace(yaml.find("chip: gpiochip0"), 15, "chip: gpiochip7");
  Rig r3(yaml.c_str());
  s = r3.driver->start_io();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("gpio driver 'dio': GPIO chip 'gpiochip7' cannot be opened"), std::string::npos)
      << s.error();
}

TEST(GpioDriver, a_busy_line_fails_the_start_saying_who_holds_it) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  auto chip = r.chips.ops().open(r.chips.ops().context, "gpiochip0");
  ASSERT_TRUE(chip.ok());
  LineRequest req;
  req.offset = 4;
  auto l = r.chips.ops().request(*chip, req, "someone");
  ASSERT_FALSE(l.ok());
  EXPECT_NE(l.error().find("used by 'rtplc-dio'"), std::string::npos) << l.error();
}

// The fake's bounded event queue, as the kernel's 16-event line queue: edges
// beyond the limit are dropped and counted; once read, there is room again.
TEST(FakeChips, drops_edges_beyond_a_lines_event_limit_and_counts_them) {
  FakeChips chips;
  chips.add_chip("gpiochip0", "gpio-fake.0", 4);
  chips.limit_events(3);
  const ChipOps& ops = chips.ops();
  auto chip = ops.open(ops.context, "gpiochip0");
  ASSERT_TRUE(chip.ok()) << chip.error();
  LineRequest req;
  req.offset = 1;
  req.edge = Edge::kRising;
  auto line = ops.request(*chip, req, "test");
  ASSERT_TRUE(line.ok()) << line.error();
  for (int i = 0; i < 5; ++i) {
    chips.pull("gpiochip0", 1, 1, 10 * i);
    chips.pull("gpiochip0", 1, 0, 10 * i + 5);  // a falling edge: not asked for, not queued
  }
  EXPECT_EQ(chips.events_dropped(), 2u);
  EdgeEvent evs[8];
  ASSERT_EQ(ops.read_events(*line, evs, 8), 3);
  EXPECT_EQ(evs[0].ts_ns, 0);
  EXPECT_EQ(evs[2].ts_ns, 20);
  chips.pull("gpiochip0", 1, 1, 100);
  ASSERT_EQ(ops.read_events(*line, evs, 8), 1);
  EXPECT_EQ(evs[0].ts_ns, 100);
  EXPECT_EQ(chips.events_dropped(), 2u);
  ops.release(*line);
}

// Real-time hygiene (kernel_rt/cycle_scope.h): the bridge's cycles allocate
// nothing through every fault they log: reads and sets failing and working
// again, outputs the task cannot vouch for.
TEST(GpioDriver, its_cycles_allocate_nothing_whatever_the_faults) {
  Rig r;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(1, 0);
  r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  testing::AllocationCounter count;
  for (int i = 0; i < 40; ++i) {
    if (i == 5) r.chips.fail_io(EIO), r.outputs(0, 1);  // a set that fails, and reads
    if (i == 10) r.chips.fail_io(0);
    if (i == 15) r.outputs(0, 1, Quality::kBad);
    if (i == 20) r.outputs(i % 2, 1);
    r.driver->cycle_now(kernel_rt::monotonic_now_ns());
  }
  EXPECT_EQ(count.in_cycles(), 0u) << "first allocation on thread '" << count.first_thread() << "'";
  EXPECT_TRUE(r.logged("driving gpiochip0 line 4 failed"));
}

}  // namespace
}  // namespace rtplc::gpio
