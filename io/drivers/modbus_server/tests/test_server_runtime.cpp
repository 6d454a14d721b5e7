// The modbus-server inside a running runtime, read and written by Debian's
// mbpoll (an independent Modbus master): the seed-like loop takes its process
// value from the fake slave through the modbus driver, and SCADA reads
// ProcVal, ManiVal and Setpoint from our server, writes Setpoint (which the
// runtime takes and retains, as `rtplc set` would), is refused when it writes
// an output, never gets a number for a channel gone bad, and many masters at
// once are each answered. Tests skip, saying why, when mbpoll is missing.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "io/drivers/modbus/fake_slave.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/eventually.h"

namespace rtplc::sched {
namespace {

using modbus::FakeSlave;
using modbus::parse_address;
using rtplc::testing::RuntimeFixture;

using rtplc::testing::eventually;

bool have_mbpoll() { return std::system("command -v mbpoll >/dev/null 2>&1") == 0; }

// A port nobody listens on now (the kernel's choice for port 0).
uint16_t free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

struct Mbpoll {
  int status = -1;
  std::string out;
};

// mbpoll with 0-based references, big-endian words, one poll.
Mbpoll mbpoll(uint16_t port, const std::string& args) {
  const std::string cmd = "mbpoll -m tcp -p " + std::to_string(port) + " -a 1 -0 -B -1 -o 5 " + args + " 2>&1";
  Mbpoll r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  char buf[512];
  while (size_t n = std::fread(buf, 1, sizeof buf, p)) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// The value mbpoll printed for reference `ref` ("[2]: 	7.5").
double printed(const Mbpoll& m, int ref) {
  const std::string tag = "[" + std::to_string(ref) + "]:";
  const size_t at = m.out.find(tag);
  if (at == std::string::npos) return -99999;
  return std::strtod(m.out.c_str() + at + tag.size(), nullptr);
}

const char* kProgram =
    "%%\nstime(0.02)\n"
    "F1 = prr(p1, d0, c0, \"ProcVal\")\n"
    "F2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F3 = sub(F2, F1, 1)\n"
    "pwr(F3, p1, d0, c1, \"ManiVal\")\n"
    "D4 = dsp(d0, c1, 0, \"Enable\")\n"
    "END\n";

class ServerRuntime : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_mbpoll()) GTEST_SKIP() << "mbpoll is not installed (scripts/setup-deps installs it)";
    ASSERT_TRUE(slave_.start().ok());
    slave_.put(*parse_address("hr:0:f32"), 42.5);
    fx_.write("p.fbd", kProgram);
    port_ = free_port();
    rt_ = fx_.start(
        "tasks:\n  - {name: loop, program: p.fbd}\n"
        "drivers:\n"
        // A loaded machine may starve the client's line thread past the
        // default age (three polls): the inputs would go stale for a moment,
        // and the server rightly answer exception 4. Freshness is not what
        // these tests are about (test_wrong_data.cpp is): a generous max_age.
        "  - kind: modbus\n    name: field\n    period: 10ms\n    max_age: 2s\n"
        "    slaves: [{name: plc1, address: 127.0.0.1, port: " + std::to_string(slave_.port()) +
        ", poll: 20ms, timeout: 100ms, retries: 0}]\n"
        "    read: [{device: R, channel: p1.d0.c0, slave: plc1, address: 0, type: f32}]\n"
        "    write: [{device: R, channel: p1.d0.c1, slave: plc1, address: 2, type: f32}]\n"
        "  - kind: modbus-server\n    name: scada\n    port: " + std::to_string(port_) + "\n"
        "    max_clients: 32\n"
        "    expose:\n"
        "      - {label: ProcVal, table: ir, address: 0, type: f32}\n"
        "      - {label: ManiVal, table: ir, address: 2, type: f32}\n"
        "      - {label: Setpoint, table: hr, address: 0, type: f32}\n"
        "      - {label: ManiVal, table: hr, address: 4, type: f32}\n"
        "      - {label: Setpoint, table: hr, address: 6, type: i16, scale: 0.1}\n"
        "      - {label: Enable, table: coil, address: 0}\n"
        "    writable: [Setpoint, Enable]\n");
    ASSERT_NE(rt_, nullptr);
    ASSERT_TRUE(eventually([&] { return quality("ProcVal") == Quality::kGood && value("ManiVal") == 7.5; }));
  }
  void TearDown() override {
    if (rt_) rt_->stop();
  }
  io::ChannelValue channel(const char* label) {
    return rt_->image().read_channel(static_cast<uint32_t>(rt_->image().find_channel(label)));
  }
  double value(const char* label) { return channel(label).value; }
  Quality quality(const char* label) { return channel(label).quality; }
  std::string retained() {
    std::ifstream f(rt_->retain_path());
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  }
  const io::LinkStatus& server_row() { return rt_->image().link(1); }  // after the slave's

  FakeSlave slave_;
  RuntimeFixture fx_;
  uint16_t port_ = 0;
  std::unique_ptr<Runtime> rt_;
};

TEST_F(ServerRuntime, mbpoll_reads_the_process_value_the_output_and_the_set_point) {
  const Mbpoll in = mbpoll(port_, "-t 3:float -r 0 -c 2 127.0.0.1");
  ASSERT_EQ(in.status, 0) << in.out;
  EXPECT_EQ(printed(in, 0), 42.5) << in.out;
  EXPECT_EQ(printed(in, 2), 7.5) << in.out;
  const Mbpoll sp = mbpoll(port_, "-t 4:float -r 0 -c 1 127.0.0.1");
  ASSERT_EQ(sp.status, 0) << sp.out;
  EXPECT_EQ(printed(sp, 0), 50) << sp.out;
  const Mbpoll scaled = mbpoll(port_, "-t 4 -r 6 -c 1 127.0.0.1");
  ASSERT_EQ(scaled.status, 0) << scaled.out;
  EXPECT_EQ(printed(scaled, 6), 500) << scaled.out;  // 50 / 0.1
  EXPECT_TRUE(eventually([&] { return server_row().polls_completed.load() >= 3; }));
  EXPECT_EQ(server_row().state.load(), static_cast<uint8_t>(io::LinkState::kUp));
  EXPECT_GE(server_row().connects.load(), 3u);
}

TEST_F(ServerRuntime, a_set_point_written_by_mbpoll_is_taken_and_retained_like_rtplc_set) {
  const Mbpoll w = mbpoll(port_, "-t 4:float -r 0 127.0.0.1 60");
  ASSERT_EQ(w.status, 0) << w.out;
  EXPECT_EQ(value("Setpoint"), 60);
  // Retained with the control thread's next save (its tick).
  ASSERT_TRUE(rt_->flush_setpoints());
  EXPECT_NE(retained().find("Setpoint 60\n"), std::string::npos) << retained();
  // The loop follows: 60 - 42.5.
  EXPECT_TRUE(eventually([&] { return value("ManiVal") == 17.5; })) << value("ManiVal");
  const Mbpoll back = mbpoll(port_, "-t 4:float -r 0 -c 1 127.0.0.1");
  EXPECT_EQ(printed(back, 0), 60) << back.out;
  // Scaled: raw 655 -> 65.5. And a digital set-point through its coil.
  ASSERT_EQ(mbpoll(port_, "-t 4 -r 6 127.0.0.1 655").status, 0);
  EXPECT_EQ(value("Setpoint"), 65.5);
  ASSERT_EQ(mbpoll(port_, "-t 0 -r 0 127.0.0.1 1").status, 0);
  EXPECT_EQ(value("Enable"), 1);
  EXPECT_TRUE(eventually([&] { return server_row().writes_acked.load() == 3; }));
}

// `rtplc set` (the control thread's set_value) and SCADA's writes at once:
// both go through one lock, so whichever came last is both the value in the
// image and the value on disk.
TEST_F(ServerRuntime, rtplc_set_and_scada_writes_at_once_leave_the_image_and_the_retain_file_agreeing) {
  std::thread operator_thread([&] {
    for (int i = 1; i <= 40; ++i) EXPECT_TRUE(rt_->set_value("Setpoint", i).ok());
  });
  for (int i = 0; i < 5; ++i) EXPECT_EQ(mbpoll(port_, "-t 4:float -r 0 127.0.0.1 77").status, 0);
  operator_thread.join();
  ASSERT_TRUE(rt_->flush_setpoints());
  const double now = value("Setpoint");
  EXPECT_TRUE(now == 40 || now == 77) << now;
  const std::string kept = retained();
  const std::string expect = now == 40 ? "Setpoint 40\n" : "Setpoint 77\n";
  EXPECT_NE(kept.find(expect), std::string::npos) << kept << " vs " << now;
  EXPECT_TRUE(eventually([&] { return server_row().writes_acked.load() == 5; }));  // the row follows a cycle later
}

// Network writes are not fsynced one by one: a SCADA writing a set-point many
// times a second costs one save per control tick. The retain file is replaced
// (a new inode) by each save, so its inode tells how many happened.
TEST_F(ServerRuntime, set_point_writes_over_modbus_are_saved_together_not_one_fsync_each) {
  ASSERT_TRUE(rt_->flush_setpoints());
  ASSERT_TRUE(rt_->set_value("Setpoint", 51).ok());  // durable: on disk now
  struct stat before {};
  ASSERT_EQ(stat(rt_->retain_path().c_str(), &before), 0);
  for (int v = 61; v <= 65; ++v) {
    ASSERT_EQ(mbpoll(port_, "-t 4:float -r 0 127.0.0.1 " + std::to_string(v)).status, 0);
  }
  EXPECT_EQ(value("Setpoint"), 65);
  struct stat mid {};
  ASSERT_EQ(stat(rt_->retain_path().c_str(), &mid), 0);
  EXPECT_EQ(mid.st_ino, before.st_ino) << "a Modbus write saved the retain file on its own";
  EXPECT_NE(retained().find("Setpoint 51\n"), std::string::npos) << retained();
  ASSERT_TRUE(rt_->flush_setpoints());  // what the control thread's tick does
  struct stat after {};
  ASSERT_EQ(stat(rt_->retain_path().c_str(), &after), 0);
  EXPECT_NE(after.st_ino, before.st_ino);
  EXPECT_NE(retained().find("Setpoint 65\n"), std::string::npos) << retained();
  // Every write is in the audit trail, as the driver's own caller.
  std::ifstream audit(rt_->api().audit().path());
  std::stringstream trail;
  trail << audit.rdbuf();
  EXPECT_NE(trail.str().find("driver scada (modbus-server) [operator] set label=Setpoint value=63: Setpoint = 63 (was 62)"),
            std::string::npos)
      << trail.str();
}

TEST_F(ServerRuntime, a_write_to_an_output_is_refused_and_the_output_stays_the_tasks) {
  const Mbpoll w = mbpoll(port_, "-t 4:float -r 4 127.0.0.1 99");
  EXPECT_NE(w.status, 0) << w.out;
  EXPECT_NE(w.out.find("llegal data address"), std::string::npos) << w.out;
  const Mbpoll ir = mbpoll(port_, "-t 4 -r 2 127.0.0.1 1");  // nothing exposed at hr 2
  EXPECT_NE(ir.status, 0) << ir.out;
  EXPECT_EQ(value("ManiVal"), 7.5);
  EXPECT_EQ(value("Setpoint"), 50);
  EXPECT_TRUE(eventually([&] { return server_row().writes_failed.load() == 2; }));
  EXPECT_EQ(server_row().writes_acked.load(), 0u);
}

TEST_F(ServerRuntime, a_channel_gone_bad_is_answered_with_exception_4_never_a_number) {
  slave_.kill();
  ASSERT_TRUE(eventually([&] { return quality("ProcVal") == Quality::kBad; }));
  const Mbpoll in = mbpoll(port_, "-t 3:float -r 0 -c 1 127.0.0.1");
  EXPECT_NE(in.status, 0) << in.out;
  EXPECT_EQ(in.out.find("42.5"), std::string::npos) << in.out;
  EXPECT_NE(in.out.find("ailure"), std::string::npos) << in.out;  // "Slave device or server failure"
  // The set-point is still served.
  EXPECT_EQ(printed(mbpoll(port_, "-t 4:float -r 0 -c 1 127.0.0.1"), 0), 50);
}

TEST_F(ServerRuntime, many_mbpoll_masters_at_once_are_each_answered) {
  constexpr uint64_t kMasters = 12;
  std::vector<pid_t> pids;
  for (uint64_t i = 0; i < kMasters; ++i) {
    const pid_t pid = fork();
    if (pid == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      ::dup2(null, 2);
      const std::string port = std::to_string(port_);
      // Polls every 20 ms on one connection until told to stop: the masters overlap.
      execlp("mbpoll", "mbpoll", "-m", "tcp", "-p", port.c_str(), "-a", "1", "-0", "-B", "-o", "5", "-t",
             "3:float", "-r", "0", "-c", "2", "-l", "20", "127.0.0.1", static_cast<char*>(nullptr));
      _exit(127);
    }
    pids.push_back(pid);
  }
  const io::LinkStatus& row = server_row();
  // All of them connected at once, each answered many times, none refused or failed.
  EXPECT_TRUE(eventually([&] { return row.polls_offline.load() == kMasters; }, 30)) << row.polls_offline.load();
  EXPECT_TRUE(eventually([&] { return row.polls_completed.load() >= kMasters * 10; }, 30));
  EXPECT_EQ(row.reconnects.load(), 0u);
  EXPECT_EQ(row.errors.load(), 0u);
  for (pid_t pid : pids) kill(pid, SIGINT);  // our own children, by pid
  for (pid_t pid : pids) waitpid(pid, nullptr, 0);
  EXPECT_TRUE(eventually([&] { return row.polls_offline.load() == 0; }));
  EXPECT_EQ(row.connects.load(), kMasters);
}

// Writes are off unless the config lists the set-point in `writable`: Modbus
// TCP has no authentication, and loopback alone admits every local user.
TEST(ServerRuntimeConfig, a_server_without_writable_refuses_every_write_and_changes_nothing) {
  if (!have_mbpoll()) GTEST_SKIP() << "mbpoll is not installed (scripts/setup-deps installs it)";
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  const uint16_t port = free_port();
  auto rt = fx.start("tasks:\n  - {name: loop, program: p.fbd}\n"
                     "drivers:\n  - kind: modbus-server\n    name: scada\n    port: " + std::to_string(port) +
                     "\n    expose:\n      - {label: Setpoint, table: hr, address: 0, type: f32}\n");
  ASSERT_NE(rt, nullptr);
  const int c = rt->image().find_channel("Setpoint");
  ASSERT_GE(c, 0);
  const double before = rt->image().read_channel(static_cast<uint32_t>(c)).value;
  const Mbpoll w = mbpoll(port, "-t 4:float -r 0 127.0.0.1 60");
  EXPECT_NE(w.status, 0) << "a write went through: " << w.out;
  EXPECT_EQ(rt->image().read_channel(static_cast<uint32_t>(c)).value, before);
  // Reading still works.
  const Mbpoll r = mbpoll(port, "-t 4:float -r 0 -c 1 127.0.0.1");
  EXPECT_EQ(r.status, 0) << r.out;
  rt->stop();
  // `writable` may name only what is exposed in hr or coil.
  std::string errors;
  EXPECT_EQ(fx.load("tasks:\n  - {name: loop, program: p.fbd}\n"
                    "drivers:\n  - kind: modbus-server\n    name: scada\n    port: 1502\n    expose:\n"
                    "      - {label: ProcVal, table: ir, address: 0, type: f32}\n    writable: [ProcVal]\n",
                    &errors),
            nullptr);
  EXPECT_NE(errors.find("'writable' names \"ProcVal\", which no `expose` entry serves in hr or coil"),
            std::string::npos) << errors;
}

TEST(ServerRuntimeConfig, an_exposed_label_no_program_has_is_refused_with_its_line) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  std::string errors;
  auto rt = fx.load(
      "tasks:\n  - {name: loop, program: p.fbd}\n"
      "drivers:\n  - kind: modbus-server\n    name: scada\n    port: 1502\n    expose:\n"
      "      - {label: ProcVal, table: ir, address: 0, type: f32}\n"
      "      - {label: Nobody, table: ir, address: 2}\n",
      &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("no channel is labelled \"Nobody\""), std::string::npos) << errors;
  EXPECT_NE(errors.find("expose entry at line"), std::string::npos) << errors;
  errors.clear();
  rt = fx.load(
      "tasks:\n  - {name: loop, program: p.fbd}\n"
      "drivers:\n  - kind: modbus-server\n    name: scada\n    port: 1502\n    expose:\n"
      "      - {label: Setpoint, table: coil, address: 0}\n",
      &errors);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(errors.find("\"Setpoint\" is analog"), std::string::npos) << errors;
}

}  // namespace
}  // namespace rtplc::sched
