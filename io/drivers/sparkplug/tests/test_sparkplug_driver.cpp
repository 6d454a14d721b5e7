// The sparkplug driver on a process image with a real broker (Debian's
// mosquitto, started here): the link thread births the task as a device and
// publishes its outputs as they change, the link row says so, and the bridge
// thread's cycles allocate nothing meanwhile (kernel_rt/cycle_scope.h).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "io/drivers/lifecycle.h"
#include "io/drivers/sparkplug/driver.h"
#include "io/drivers/sparkplug/mqtt_session.h"
#include "kernel_rt/clock.h"
#include "sched/image_plan.h"
#include "tests/support/alloc_counter.h"
#include "tests/support/driver_test.h"
#include "tests/support/eventually.h"

namespace rtplc::sparkplug {
namespace {

using namespace std::chrono_literals;  // sleep_for

constexpr int64_t kMs = kernel_rt::kNsPerMs;

// mosquitto on a port of its own, for one test.
class Mosquitto {
 public:
  Mosquitto() {
    if (access("/usr/sbin/mosquitto", X_OK) != 0) return;
    port_ = static_cast<uint16_t>(20000 + getpid() % 20000);
    pid_ = fork();
    if (pid_ == 0) {
      const std::string p = std::to_string(port_);
      freopen("/dev/null", "w", stdout);
      freopen("/dev/null", "w", stderr);
      execl("/usr/sbin/mosquitto", "mosquitto", "-p", p.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    // Listening once a session can come up.
    SparkplugSettings s;
    s.port = port_;
    ok_ = testing::eventually([&] {
      MqttSession m(s, "probe");
      if (!m.connect("", "", 0)) return false;
      for (int i = 0; i < 20 && !m.up(); ++i) m.loop(10);
      return m.up();
    }, 10);
  }
  ~Mosquitto() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  bool ok() const { return ok_; }
  uint16_t port() const { return port_; }

 private:
  pid_t pid_ = -1;
  uint16_t port_ = 0;
  bool ok_ = false;
};

TEST(SparkplugDriver, publishes_a_tasks_outputs_and_its_bridge_cycles_allocate_nothing) {
  Mosquitto broker;
  if (!broker.ok()) GTEST_SKIP() << "no mosquitto broker at /usr/sbin/mosquitto (scripts/setup-deps installs it)";
  auto cfg = test::parse_driver("sparkplug", "plant",
                                "    broker: 127.0.0.1:" + std::to_string(broker.port()) +
                                    "\n    group: G\n    node: N\n");
  ASSERT_TRUE(cfg.ok()) << cfg.render();
  io::ProcessImage image = test::driver_image("spb", "plant", 0, 2);
  for (uint32_t i = 0; i < 2; ++i) {
    io::ChannelDesc d = sched::channel_desc("Out" + std::to_string(i), "out/ETH/p0.d0.c" + std::to_string(i),
                                            io::ChannelDir::kOutput, 0, 0, i);
    d.users = 1;  // task 0's
    ASSERT_TRUE(image.add_channel(d).ok());
  }
  std::strcpy(image.task_info(0).name, "t");
  image.task_info(0).state.store(static_cast<uint8_t>(io::TaskState::kRunning));
  io::LinkEventQueue events;
  io::DriverSetup setup = test::driver_setup(cfg.config->drivers[0], image, events, 0, 0, 5 * kMs);
  auto drv = io::create_prepared<SparkplugDriver>(setup);
  ASSERT_TRUE(drv.ok()) << drv.error();
  auto* node = static_cast<SparkplugDriver*>(drv->get());

  // A host: our session as a plain subscriber.
  SparkplugSettings hs;
  hs.port = broker.port();
  MqttSession host(hs, "host");
  ASSERT_TRUE(host.connect("", "", 0).ok());
  ASSERT_TRUE(testing::eventually([&] { return host.loop(10), host.up(); }, 5));
  host.subscribe("spBv1.0/G/#", 0);
  host.loop(50);

  test::put_task_outputs(image, {1, 2});
  ASSERT_TRUE((*drv)->start(kernel_rt::monotonic_now_ns()).ok());
  std::vector<MqttSession::Message> seen;
  auto saw = [&](const std::string& topic) {
    host.loop(10);
    for (auto& m : host.take_messages()) seen.push_back(std::move(m));
    for (const auto& m : seen) {
      if (m.topic == topic) return true;
    }
    return false;
  };
  ASSERT_TRUE(testing::eventually([&] { return saw("spBv1.0/G/DBIRTH/N/t"); }, 10));
  {
    testing::AllocationCounter count;
    for (int i = 0; i < 40; ++i) {
      test::put_task_outputs(image, {10.0 + i, 2});
      std::this_thread::sleep_for(10ms);
      host.loop(1);
    }
    EXPECT_EQ(count.in_cycles(), 0u) << "first allocation on thread '" << count.first_thread() << "'";
  }
  // The last value written reaches the host (the ones before may be skipped
  // between two samples: Sparkplug sends what the image holds when it looks).
  auto last_out0 = [&] {
    saw("");
    double v = -1;
    for (const auto& m : seen) {
      Payload p;
      if (m.topic != "spBv1.0/G/DDATA/N/t" || !p.ParseFromString(m.payload)) continue;
      for (const Metric& x : p.metrics()) {
        if (x.name() == "Out0") v = x.double_value();
      }
    }
    return v;
  };
  EXPECT_TRUE(testing::eventually([&] { return last_out0() == 49.0; }, 10)) << last_out0();

  const io::LinkStatus& row = image.link(0);
  EXPECT_TRUE(testing::eventually([&] { return row.state.load() == static_cast<uint8_t>(io::LinkState::kUp); }, 5));
  EXPECT_STREQ(row.gauge_names[0], "births");
  EXPECT_EQ(row.gauges[0].load(), 1u);
  EXPECT_GE(row.polls_completed.load(), 3u) << "NBIRTH, DBIRTH, DDATA...";
  EXPECT_EQ(node->counters().node_births.load(), 1u);

  // An orderly stop: the device dies (the task stopped) and the node with it.
  image.task_info(0).state.store(static_cast<uint8_t>(io::TaskState::kStopped));
  EXPECT_TRUE(testing::eventually([&] { return saw("spBv1.0/G/DDEATH/N/t"); }, 5));
  (*drv)->request_stop();
  (*drv)->join();
  drv->reset();
  EXPECT_TRUE(testing::eventually([&] { return saw("spBv1.0/G/NDEATH/N"); }, 5));
}

}  // namespace
}  // namespace rtplc::sparkplug
