// A Modbus RTU line on a fieldbus plan (docs/fieldbus.md, "Running a link on a
// plan") against the fake slave on a socat pty pair, in real time with counts
// and order only: each loop's read request in its own T_1 frames (L1 every
// frame, L2 every 4th), the non-RT range read in requests of at most L_n of
// data (one a frame, after the frame's periodic reads), the urgent write sent;
// and the config's refusals of what the plan does not describe.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "config/config.h"
#include "io/drivers/modbus/config.h"
#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/line.h"
#include "io/drivers/modbus/tests/fake_rtu_line.h"

namespace rtplc::modbus {
namespace {

// 19200 baud, 11 bits a character: L_p = 4 characters (2.29 ms), T_1 = 100 ms,
// L_n max = 43.85 ms = 76 characters = 38 registers of data.
const char* kPlan =
    "link: {nodes: 4, bit_rate: 19200, layout: modbus-rtu}\n"
    "periodic: {bytes: 4}\n"
    "realtime: {queues: 1, bytes: 2}\n"
    "loops:\n"
    "  - {name: L1, period: 100ms}\n"
    "  - {name: L2, max_delay: 500ms}\n";

struct Dir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("rtplc-mbplan-" + std::to_string(getpid()));
  Dir() { std::filesystem::create_directories(path); }
  ~Dir() { std::filesystem::remove_all(path); }
};

std::string driver_yaml(const std::string& device, const std::string& extra_reads = "") {
  std::string y =
      "tasks:\n  - {name: t, program: p.fbd}\n"
      "drivers:\n  - kind: modbus\n    name: field\n    period: 10ms\n    slaves:\n"
      "      - {name: meter, device: " + device + ", baud: 19200, parity: N, unit: 7, plan: plan.yaml, timeout: 300ms}\n"
      "    read:\n"
      "      - {device: R, channel: p0.d0.c0, slave: meter, address: 0, type: f32, loop: L1}\n"
      "      - {device: R, channel: p0.d0.c1, slave: meter, address: 10, type: f32, loop: L2}\n" + extra_reads;
  // 60 registers read as non-RT: two requests of at most 38.
  for (int i = 0; i < 60; ++i) {
    y += "      - {device: R, channel: p0.d1.c" + std::to_string(i) + ", slave: meter, address: " +
         std::to_string(200 + i) + ", class: nonrt, poll: 1s}\n";
  }
  y += "    write:\n      - {device: R, channel: p0.d2.c0, slave: meter, address: 50}\n";
  return y;
}

config::LoadResult load(const Dir& d, const std::string& plan, const std::string& yaml) {
  std::ofstream(d.path / "plan.yaml") << plan;
  return config::parse_config(yaml, "c.yaml", d.path.string(), config::LoadOptions{false});
}

TEST(ModbusPlan, reads_each_loop_in_its_frames_cuts_nonrt_to_ln_and_sends_urgent_writes) {
  testing::FakeRtuLine rtu({7});
  if (!rtu.available()) GTEST_SKIP() << rtu.why();
  Dir dir;
  auto cfg = load(dir, kPlan, driver_yaml(rtu.device()));
  ASSERT_TRUE(cfg.ok()) << cfg.render();
  const ModbusSettings& s = settings_of(cfg.config->drivers[0]);
  ASSERT_TRUE(s.slaves[0].plan);
  const fieldbus::Plan& plan = s.slaves[0].plan->plan;
  ASSERT_EQ(plan.t1, 100'000'000);
  ASSERT_TRUE(rtu.start().ok());
  FakeSlave& slave = rtu.slave();
  Exchange x(s.reads.size(), s.writes.size(), s.slaves.size());
  LineOptions opt;
  opt.wake_ns = 10'000'000;
  Line line(s, std::vector<uint32_t>{0}, x, opt);
  ASSERT_TRUE(line.planned());
  ASSERT_TRUE(line.start().ok());
  auto count = [&](uint16_t address) {
    size_t n = 0;
    for (const FakeSlave::LoggedRequest& r : slave.request_log()) n += r.function == 3 && r.address == address;
    return n;
  };
  // Waits by counts (the bound only keeps a broken build from hanging).
  for (int i = 0; i < 3000 && count(0) < 3; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  WriteJob job;
  job.write = 0;
  job.seq = 1;
  job.words[0] = 1234;
  ASSERT_TRUE(line.push(job));
  for (int i = 0; i < 3000 && count(0) < 14; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  line.join();
  slave.stop();

  const std::vector<FakeSlave::LoggedRequest> log = slave.request_log();
  ASSERT_GE(count(0), 14u);
  std::map<int64_t, std::vector<FakeSlave::LoggedRequest>> by_frame;  // frames lie on the clock's multiples of T_1
  for (const FakeSlave::LoggedRequest& r : log) by_frame[r.at_ns / plan.t1].push_back(r);
  std::vector<int64_t> l2_frames;
  int nonrt_requests = 0;
  uint32_t nonrt_registers = 0;
  int writes = 0;
  for (const auto& [f, reqs] : by_frame) {
    int l1 = 0, nonrt = 0;
    bool nonrt_seen = false;
    for (const FakeSlave::LoggedRequest& r : reqs) {
      if (r.function == 6 || r.function == 16) {
        ++writes;
        EXPECT_EQ(r.address, 50);
        continue;
      }
      ASSERT_EQ(r.function, 3);
      if (r.address == 0) {
        ++l1;
        EXPECT_FALSE(nonrt_seen) << "a periodic read after the non-RT one in frame " << f;
      } else if (r.address == 10) {
        l2_frames.push_back(f);
        EXPECT_FALSE(nonrt_seen) << "a periodic read after the non-RT one in frame " << f;
      } else {
        EXPECT_GE(r.address, 200);
        EXPECT_LE(r.count, 38) << "a non-RT request longer than L_n";
        ++nonrt;
        ++nonrt_requests;
        nonrt_registers += r.count;
        nonrt_seen = true;
      }
    }
    EXPECT_LE(l1, 1) << "two L1 reads in frame " << f;
    EXPECT_LE(nonrt, 1) << "two non-RT requests in frame " << f;
  }
  ASSERT_GE(l2_frames.size(), 2u);
  for (size_t i = 1; i < l2_frames.size(); ++i) EXPECT_EQ((l2_frames[i] - l2_frames[i - 1]) % 4, 0);
  EXPECT_GE(nonrt_requests, 2);
  // Each pass over the range: 200+38 then 238+22, in order (the run may end between them).
  uint16_t expect = 200;
  for (const FakeSlave::LoggedRequest& r : log) {
    if (r.function != 3 || r.address < 200) continue;
    EXPECT_EQ(r.address, expect) << "the non-RT range is not read in order";
    EXPECT_EQ(r.count, r.address == 200 ? 38 : 22);
    expect = r.address == 200 ? 238 : 200;
  }
  EXPECT_GE(nonrt_registers, 60u);
  EXPECT_EQ(writes, 1);
  EXPECT_EQ(slave.get(Table::kHoldingRegister, 50), 1234);
  WriteOutcome out;
  ASSERT_TRUE(x.outcomes[0].try_load(out));
  EXPECT_EQ(out.seq, 1u);
  EXPECT_EQ(out.ok, 1);
  // The line's figures, as the bridge puts them in the link row.
  fieldbus::LinkFigures fig;
  ASSERT_TRUE(x.planned[0].try_load(fig));
  EXPECT_GE(fig[0].count, 14u);
  EXPECT_EQ(fig[1].count, 1u);
  EXPECT_EQ(fig[2].count, static_cast<uint64_t>(nonrt_requests));
  EXPECT_LE(fig[2].packet_max, plan.ln_max);
  EXPECT_LE(fig[0].packet_max, s.slaves[0].plan->design.periodic_packet);
  ItemSample smp;
  ASSERT_TRUE(x.samples[2].try_load(smp));  // the first non-RT item
  EXPECT_EQ(smp.good, 1);
}

TEST(ModbusPlan, refuses_what_the_plan_does_not_describe) {
  Dir dir;
  auto r = load(dir, kPlan, driver_yaml("/dev/ttyX", "      - {device: R, channel: p0.d3.c0, slave: meter, address: 90}\n"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.render().find("is not in the plan: give it 'loop: NAME' (one of L1, L2) or 'class: nonrt'"),
            std::string::npos)
      << r.render();
  r = load(dir, kPlan,
           driver_yaml("/dev/ttyX", "      - {device: R, channel: p0.d3.c0, slave: meter, address: 90, loop: L7}\n"));
  EXPECT_NE(r.render().find("the plan has no loop 'L7' (its loops: L1, L2)"), std::string::npos) << r.render();
  // 40 registers in one L1 request: 80 bytes, far more than L_p = 4.
  std::string big;
  for (int i = 0; i < 40; ++i) {
    big += "      - {device: R, channel: p0.d4.c" + std::to_string(i) + ", slave: meter, address: " +
           std::to_string(100 + i) + ", loop: L1}\n";
  }
  r = load(dir, kPlan, driver_yaml("/dev/ttyX", big));
  EXPECT_NE(r.render().find("longer than the plan's periodic packet L_p"), std::string::npos) << r.render();
  // The plan's bit rate is the line's.
  std::string yaml = driver_yaml("/dev/ttyX");
  yaml.replace(yaml.find("baud: 19200"), 11, "baud: 9600");
  r = load(dir, kPlan, yaml);
  EXPECT_NE(r.render().find("is for 19200 bit/s, the line runs at 9600 baud"), std::string::npos) << r.render();
  // A plan that cannot work: the planner's reason.
  r = load(dir,
           "link: {nodes: 4, bit_rate: 19200, layout: modbus-rtu}\nperiodic: {bytes: 4}\n"
           "loops:\n  - {name: L1, period: 10ms}\n  - {name: L2, period: 10ms}\n",
           driver_yaml("/dev/ttyX"));
  EXPECT_NE(r.render().find("cannot work"), std::string::npos) << r.render();
  EXPECT_NE(r.render().find("stability"), std::string::npos) << r.render();
  // A TCP slave has no plan.
  r = config::parse_config(
      "tasks:\n  - {name: t, program: p.fbd}\ndrivers:\n  - kind: modbus\n    slaves:\n"
      "      - {name: pump, address: 10.0.0.2, plan: plan.yaml}\n",
      "c.yaml", dir.path.string(), config::LoadOptions{false});
  EXPECT_NE(r.render().find("'plan' applies to RTU slaves"), std::string::npos) << r.render();
}

// Two lines of slaves, all naming plan.yaml; `second_baud` is the line settings of
// /dev/ttyY's slave.
std::string shared_plan_yaml(const std::string& second_baud = "19200") {
  return "tasks:\n  - {name: t, program: p.fbd}\n"
         "drivers:\n  - kind: modbus\n    name: field\n    period: 10ms\n    slaves:\n"
         "      - {name: a, device: /dev/ttyX, baud: 19200, parity: N, unit: 7, plan: plan.yaml}\n"
         "      - {name: b, device: /dev/ttyX, baud: 19200, parity: N, unit: 8, plan: plan.yaml}\n"
         "      - {name: c, device: /dev/ttyY, baud: " + second_baud + ", parity: N, unit: 7, plan: plan.yaml}\n"
         "    read:\n"
         "      - {device: R, channel: p0.d0.c0, slave: a, address: 0, loop: L1}\n"
         "      - {device: R, channel: p0.d0.c1, slave: b, address: 0, loop: L2}\n"
         "      - {device: R, channel: p0.d0.c2, slave: c, address: 0, class: nonrt}\n";
}

TEST(ModbusPlan, shares_one_plan_between_the_slaves_naming_its_file) {
  Dir dir;
  auto r = load(dir, kPlan, shared_plan_yaml());
  ASSERT_TRUE(r.ok()) << r.render();
  const ModbusSettings& s = settings_of(r.config->drivers[0]);
  ASSERT_EQ(s.slaves.size(), 3u);
  ASSERT_TRUE(s.slaves[0].plan);
  // One object for all three: the file was read and planned once (a second
  // load would have made a second LinkPlan).
  EXPECT_EQ(s.slaves[0].plan.get(), s.slaves[1].plan.get());
  EXPECT_EQ(s.slaves[0].plan.get(), s.slaves[2].plan.get());
  EXPECT_EQ(s.slaves[0].plan.use_count(), 3);
  EXPECT_EQ(s.slaves[0].plan->plan.t1, 100'000'000);
  EXPECT_EQ(s.slaves[2].plan_file, s.slaves[0].plan->file);
}

TEST(ModbusPlan, checks_each_slave_against_the_shared_plan) {
  // The plan is shared, the line settings are not: the 9600 baud line is refused
  // at its own slave's plan key, the others load.
  Dir dir;
  auto r = load(dir, kPlan, shared_plan_yaml("9600"));
  ASSERT_FALSE(r.ok());
  const std::string out = r.render();
  EXPECT_NE(out.find("c.yaml:10:76: error: the plan " + (dir.path / "plan.yaml").string() +
                     " is for 19200 bit/s, the line runs at 9600 baud"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("c.yaml:8:"), std::string::npos) << out;
  EXPECT_EQ(out.find("c.yaml:9:"), std::string::npos) << out;
}

TEST(ModbusPlan, reports_a_bad_plan_at_every_slave_naming_it) {
  Dir dir;
  auto r = load(dir, "link: {nodes: 4, bit_rate: 19200, layout: modbus-rtu}\nperiodic: {bytes: many}\n",
                shared_plan_yaml());
  ASSERT_FALSE(r.ok());
  const std::string out = r.render();
  // The plan file's own diagnostic, once at each `plan:` that names it.
  for (const char* at : {"c.yaml:8:77: error: ", "c.yaml:9:77: error: ", "c.yaml:10:77: error: "}) {
    const size_t here = out.find(at);
    ASSERT_NE(here, std::string::npos) << at << " in\n" << out;
    EXPECT_NE(out.find("plan.yaml:2:19: error: 'bytes' expects a whole number", here), std::string::npos) << out;
  }
}

TEST(ModbusPlan, loads_the_example_and_its_plan) {
  auto r = config::load_config(std::string(RTPLC_SOURCE_DIR) + "/examples/modbus_plan.yaml",
                               config::LoadOptions{false});
  ASSERT_TRUE(r.ok()) << r.render();
  const ModbusSettings& s = settings_of(r.config->drivers[0]);
  ASSERT_TRUE(s.slaves[0].plan);
  EXPECT_EQ(s.slaves[0].plan->plan.t1, 100'000'000);
  EXPECT_EQ(s.reads[0].traffic, ChannelMap::Traffic::kPeriodic);
  EXPECT_EQ(s.reads[1].loop, "status");
  EXPECT_EQ(s.reads[2].traffic, ChannelMap::Traffic::kNonRt);
  EXPECT_EQ(s.writes[0].traffic, ChannelMap::Traffic::kUrgent);
  EXPECT_EQ(s.writes[1].traffic, ChannelMap::Traffic::kUrgent);
}

}  // namespace
}  // namespace rtplc::modbus
