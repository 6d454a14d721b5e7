// A can link that runs on a fieldbus plan (docs/fieldbus.md, "Running a link
// on a plan") over the in-process fake bus, cycles at virtual times: periodic
// frames only in their loop's T_1 frames, urgent frames first in the frame
// they change in, the bulk transfer cut into fragments of at most L_n (one a
// frame), the per-class delays in the generic link row within the plan's
// bounds; and a plan that cannot work, or frames it does not describe,
// refused with the reason and the position.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "config/config.h"
#include "io/drivers/can/config.h"
#include "io/drivers/can/driver.h"
#include "io/drivers/can/fake_bus.h"
#include "sched/stats_source.h"
#include "tests/support/driver_test.h"

namespace rtplc::can {
namespace {

constexpr int64_t kMs = 1000000;

int64_t g_now = 0;
int64_t virtual_now() noexcept { return g_now; }

// 8 nodes, 8-byte frames at 500 kbit/s (270 us): T_1 = 10 ms, L1 every frame,
// L2 every 4th, L_n max = (10ms - 2.23ms) / 5 = 1.554ms, five bulk frames.
const char* kPlan =
    "link: {nodes: 8, bit_rate: 500kbit/s, layout: can-11}\n"
    "periodic: {bytes: 8}\n"
    "realtime: {queues: 1, bytes: 8}\n"
    "loops:\n"
    "  - {name: L1, period: 10ms}\n"
    "  - {name: L2, max_delay: 50ms}\n";

const char* kDriver =
    "tasks:\n  - {name: t, program: p.fbd}\n"
    "drivers:\n  - kind: can\n    name: epc\n    period: 1ms\n    interface: vcan0\n"
    "    plan: plan.yaml\n"
    "    transmit:\n"
    "      - {id: 0x201, loop: L1, signals: [{channel: p0.d1.c0, byte: 0, length: 2}]}\n"
    "      - {id: 0x202, loop: L2, signals: [{channel: p0.d1.c1, byte: 0}]}\n"
    "      - {id: 0x0A0, class: urgent, signals: [{channel: p0.d2.c0, byte: 0}]}\n"
    "    bulk:\n"
    "      - {id: 0x5F0, file: blob.bin}\n";

struct Dir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("rtplc-canplan-" + std::to_string(getpid()));
  Dir() { std::filesystem::create_directories(path); }
  ~Dir() { std::filesystem::remove_all(path); }
  void write(const std::string& name, const std::string& text) const { std::ofstream(path / name) << text; }
};

config::LoadResult load(const Dir& d, const std::string& yaml) {
  return config::parse_config(yaml, "c.yaml", d.path.string(), config::LoadOptions{false});
}

std::string blob() {
  std::string b;
  for (int i = 0; i < 100; ++i) b += static_cast<char>(i);
  return b;
}

struct Rig {
  Dir dir;
  config::LoadResult cfg;
  io::ProcessImage image;
  FakeBus bus;
  io::LinkEventQueue events;
  std::unique_ptr<CanDriver> driver;

  explicit Rig(const char* plan = kPlan) {
    dir.write("plan.yaml", plan);
    dir.write("blob.bin", blob());
    cfg = load(dir, kDriver);
    if (!cfg.ok()) return;
    image = test::driver_image("canplan", "epc", 0, 3);
    driver = std::make_unique<CanDriver>(test::driver_setup(cfg.config->drivers[0], image, events, 0, 3, 1 * kMs),
                                         bus.transport(), &virtual_now);
  }
  void outputs(double a, double b, double c) { test::put_task_outputs(image, {a, b, c}); }
};

TEST(CanPlan, sends_periodic_frames_in_their_windows_urgent_first_and_bulk_cut_to_ln) {
  Rig r;
  ASSERT_TRUE(r.cfg.ok()) << r.cfg.render();
  const fieldbus::Plan& plan = settings_of(r.cfg.config->drivers[0]).plan->plan;
  ASSERT_EQ(plan.t1, 10 * kMs);
  ASSERT_EQ(plan.ln_max, 1554 * kMs / 1000);
  const int64_t l2_offset = plan.loops[1].offset;
  ASSERT_TRUE(r.driver->start_io().ok());
  r.outputs(1, 2, 0);
  const int64_t t0 = 1000 * kMs;
  std::map<uint32_t, std::vector<int64_t>> frames_of;  // id -> T_1 frame of each send
  std::map<int64_t, int> bulk_in_frame;
  std::string bulk_bytes;
  size_t seen = 0;
  int urgent_changes = 0;
  for (int64_t c = 0; c < 400; ++c) {  // 40 frames of 10 cycles
    const int64_t now = t0 + c * kMs;
    if (c % 37 == 5) r.outputs(1, 2, ++urgent_changes);  // the urgent value changes mid-frame
    g_now = now;
    r.driver->cycle_now(now);
    const std::vector<Frame> sent = r.bus.sent();
    const int64_t f = c / 10;
    bool first = true;
    for (size_t i = seen; i < sent.size(); ++i, first = false) {
      const Frame& fr = sent[i];
      frames_of[fr.id].push_back(f);
      if (fr.id == 0x0A0) {
        EXPECT_TRUE(first) << "urgent frame not first in cycle " << c;
      }
      if (fr.id == 0x201 || fr.id == 0x202) {
        EXPECT_EQ(c % 10, 0) << "periodic frame outside its frame's start";
      }
      if (fr.id == 0x5F0) {
        ++bulk_in_frame[f];
        bulk_bytes.append(reinterpret_cast<const char*>(fr.data), fr.len);
      }
    }
    seen = sent.size();
  }
  EXPECT_EQ(frames_of[0x201].size(), 40u);
  ASSERT_EQ(frames_of[0x202].size(), 10u);
  for (int64_t f : frames_of[0x202]) EXPECT_EQ(f % 4, l2_offset);
  EXPECT_EQ(frames_of[0x0A0].size(), static_cast<size_t>(1 + urgent_changes));  // the first value, then each change
  // 100 bytes = 13 frames, at most 5 (1.35 ms <= L_n) in one T_1 frame.
  EXPECT_EQ(frames_of[0x5F0].size(), 13u);
  for (const auto& [f, n] : bulk_in_frame) EXPECT_LE(n, 5) << "frame " << f;
  EXPECT_EQ(bulk_in_frame.size(), 3u);
  EXPECT_EQ(bulk_bytes, blob());
  EXPECT_EQ(r.driver->transfers_done(), 1u);

  // The link row: per class, measured beside the plan's bounds.
  r.driver->cycle_now(t0 + 400 * kMs);  // publishes (every 100 ms)
  const io::LinkStatus& ls = r.image.link(0);
  EXPECT_NE(std::string(ls.plan).find("plan.yaml: T1 10ms, gamma 4, Ln 1.554ms"), std::string::npos) << ls.plan;
  const io::LinkClassStatus& p = ls.classes[0];
  const io::LinkClassStatus& u = ls.classes[1];
  const io::LinkClassStatus& n = ls.classes[2];
  EXPECT_STREQ(p.name, "periodic");
  EXPECT_STREQ(u.name, "urgent");
  EXPECT_STREQ(n.name, "non-RT");
  EXPECT_EQ(p.count.load(), 52u);  // the last cycle opened frame 40: 41 of L1, 11 of L2
  EXPECT_EQ(p.missed.load(), 0u);
  EXPECT_LE(p.delay_max_ns.load(), p.delay_bound_ns.load());
  EXPECT_EQ(p.delay_bound_ns.load(), plan.transfer_bound);
  EXPECT_LE(p.packet_max_ns.load(), p.packet_bound_ns.load());
  EXPECT_EQ(u.count.load(), static_cast<uint64_t>(1 + urgent_changes));
  EXPECT_EQ(u.missed.load(), 0u);
  EXPECT_LE(u.delay_max_ns.load(), u.delay_bound_ns.load());
  EXPECT_EQ(n.count.load(), 3u);
  EXPECT_LE(n.packet_max_ns.load(), plan.ln_max);
  EXPECT_EQ(n.packet_bound_ns.load(), plan.ln_max);
  EXPECT_EQ(ls.writes_acked.load(), r.bus.sent_count());

  // What `rtplc stats` prints of it, text and JSON, without naming the kind.
  const std::string text = sched::render_links_table(r.image);
  EXPECT_NE(text.find("    plan plan.yaml: T1 10ms, gamma 4, Ln 1.554ms\n"), std::string::npos) << text;
  EXPECT_NE(text.find("    periodic: 52 sent, delay p99/max 0.0/0.0 us (bound 3784.0 us), 0 missed, packet max "
                      "270.0 us (bound 270.0 us)\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("    non-RT: 3 sent"), std::string::npos) << text;
  EXPECT_NE(text.find("(bound none)"), std::string::npos) << text;
  EXPECT_EQ(text.find("EXCEEDS"), std::string::npos) << text;
  const std::string json = sched::with_links_json(r.image, "{\n  \"tasks\": []\n}\n");
  EXPECT_NE(json.find("\"plan\": \"plan.yaml: T1 10ms, gamma 4, Ln 1.554ms\", \"classes\": [{\"name\": "
                      "\"periodic\", \"count\": 52, \"missed\": 0"),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"delay_bound\": null, \"packet_max\": 0.00135, \"packet_bound\": 0.001554, \"holds\": true}"),
            std::string::npos)
      << json;
}

TEST(CanPlan, refuses_a_plan_that_cannot_work_with_the_planners_reason) {
  // Five 2 ms loops of 8-byte frames: gamma 10 > the 8 nodes, and the periodic part overruns T_1.
  Rig r(
      "link: {nodes: 8, bit_rate: 500kbit/s, layout: can-11}\n"
      "periodic: {bytes: 8}\n"
      "realtime: {queues: 1, bytes: 8}\n"
      "loops:\n"
      "  - {name: L1, period: 2ms}\n  - {name: L2, period: 2ms}\n  - {name: L3, period: 2ms}\n"
      "  - {name: L4, period: 2ms}\n  - {name: L5, period: 2ms}\n");
  ASSERT_FALSE(r.cfg.ok());
  const std::string text = r.cfg.render();
  EXPECT_NE(text.find("c.yaml:8:11"), std::string::npos) << text;  // the 'plan' key's value
  EXPECT_NE(text.find("cannot work"), std::string::npos) << text;
  EXPECT_NE(text.find("stability"), std::string::npos) << text;
  EXPECT_NE(text.find("plan.yaml:"), std::string::npos) << text;
}

std::string error_of(const std::string& plan, const std::string& driver) {
  Dir d;
  d.write("plan.yaml", plan);
  d.write("blob.bin", "x");
  auto r = load(d, "tasks:\n  - {name: t, program: p.fbd}\ndrivers:\n  - kind: can\n    name: epc\n" + driver);
  EXPECT_FALSE(r.ok());
  return r.render();
}

TEST(CanPlan, refuses_frames_the_plan_does_not_describe) {
  const std::string head = "    period: 1ms\n    interface: vcan0\n    plan: plan.yaml\n    transmit:\n";
  std::string e = error_of(kPlan, head + "      - {id: 0x201, loop: L9, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("the plan has no loop 'L9' (its loops: L1, L2)"), std::string::npos) << e;
  e = error_of(kPlan, head + "      - {id: 0x201, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("is not in the plan"), std::string::npos) << e;
  e = error_of(kPlan, head + "      - {id: 0x201, loop: L1, period: 5ms, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("drop 'period'"), std::string::npos) << e;
  e = error_of(kPlan, "    period: 3ms\n    interface: vcan0\n    plan: plan.yaml\n    transmit:\n"
                      "      - {id: 0x201, loop: L1, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("c.yaml:6:13"), std::string::npos) << e;
  EXPECT_NE(e.find("must divide the plan's T_1 = 10ms"), std::string::npos) << e;
  // L_p of 4 bytes: an 8-byte frame is longer than the plan's packet.
  std::string small = kPlan;
  small.replace(small.find("periodic: {bytes: 8}"), 20, "periodic: {bytes: 4}");
  e = error_of(small, head + "      - {id: 0x201, loop: L1, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("longer than the plan's periodic packet L_p"), std::string::npos) << e;
  e = error_of(kPlan, head + "      - {id: 0x0A0, class: urgent, signals: [{channel: p0.d2.c0, byte: 0}]}\n"
                             "      - {id: 0x0A1, class: urgent, signals: [{channel: p0.d2.c1, byte: 0}]}\n");
  EXPECT_NE(e.find("2 urgent frames, but the plan reserves 1 real-time queues"), std::string::npos) << e;
  // Without a plan: neither loops nor bulk.
  e = error_of(kPlan, "    interface: vcan0\n    transmit:\n"
                      "      - {id: 0x201, loop: L1, signals: [{channel: p0.d1.c0, byte: 0}]}\n"
                      "    bulk: [{id: 0x5F0, file: blob.bin}]\n");
  EXPECT_NE(e.find("which needs the driver's 'plan'"), std::string::npos) << e;
  EXPECT_NE(e.find("'bulk' needs the driver's 'plan'"), std::string::npos) << e;
  // A Modbus layout is no CAN plan; a missing file is named.
  const std::string modbus =
      "link: {nodes: 2, bit_rate: 115200, layout: modbus-rtu}\nperiodic: {bytes: 4}\n"
      "loops:\n  - {name: L1, period: 100ms}\n";
  e = error_of(modbus, head + "      - {id: 0x201, loop: L1, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("gives no CAN frame layout"), std::string::npos) << e;
  e = error_of(kPlan, "    period: 1ms\n    interface: vcan0\n    plan: nope.yaml\n    transmit:\n"
                      "      - {id: 0x201, loop: L1, signals: [{channel: p0.d1.c0, byte: 0}]}\n");
  EXPECT_NE(e.find("nope.yaml"), std::string::npos) << e;
}

TEST(CanPlan, loads_the_example_and_its_plan) {
  auto r = config::load_config(std::string(RTPLC_SOURCE_DIR) + "/examples/drive_plan.yaml",
                               config::LoadOptions{false});
  ASSERT_TRUE(r.ok()) << r.render();
  const CanSettings& s = settings_of(r.config->drivers[0]);
  ASSERT_TRUE(s.plan);
  EXPECT_EQ(s.plan->plan.t1, 10 * kMs);
  EXPECT_EQ(s.plan->plan.gamma, 4);
  EXPECT_EQ(s.plan->plan.ln_max, 1554000);
  ASSERT_EQ(s.transmit.size(), 2u);
  EXPECT_EQ(s.transmit[0].loop, "speed");
  EXPECT_EQ(s.transmit[1].tx_class, FrameMap::Class::kUrgent);
  ASSERT_EQ(s.bulk.size(), 1u);
  EXPECT_EQ(s.bulk[0].id, 0x5F0u);
  EXPECT_DOUBLE_EQ(s.bulk[0].every_s, 2.0);
}

}  // namespace
}  // namespace rtplc::can
