// The client against a real S7 server: node-snap7's S7Server, installed by
// scripts/setup-s7-peer and started on loopback by io/drivers/s7/tests/snap7_server.js
// (issue 4, item 6a). Values are checked both ways: set in the server and read by
// us, written by us and read back from the server's memory.
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "io/drivers/s7/engine.h"
#include "io/drivers/s7/session.h"
#include "io/link/socket_util.h"
#include "io/drivers/s7/tests/s7_test_util.h"

namespace rtplc::s7 {
namespace {

std::string peer_dir() {
  if (const char* d = std::getenv("RTPLC_S7_PEER_DIR"); d != nullptr && *d != '\0') return d;
  return std::string(RTPLC_SOURCE_DIR) + "/build/s7-peer";
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

uint16_t free_port() {
  auto ep = parse_endpoint("127.0.0.1", 0);
  auto fd = listen_on(*ep, 1);
  return fd ? local_port(fd->get()) : 0;
}

// The snap7 server as a child process speaking line commands over pipes.
class Snap7Peer {
 public:
  // Empty on success, else why it could not start.
  std::string start() {
    const std::string dir = peer_dir();
    if (!exists(dir + "/node_modules/node-snap7/package.json")) {
      return "node-snap7 is not installed in " + dir + " (run scripts/setup-s7-peer)";
    }
    for (int attempt = 0; attempt < 3; ++attempt) {
      port_ = free_port();
      const std::string err = spawn(dir);
      if (err.empty()) return {};
      stop();
      if (err.find("cannot listen") == std::string::npos) return err;
    }
    return "snap7 server could not listen on a free port";
  }

  void stop() {
    if (pid_ > 0) {
      (void)command("quit");
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
    to_.reset();
    from_.reset();
  }
  ~Snap7Peer() { stop(); }

  uint16_t port() const { return port_; }

  std::string command(const std::string& line) {
    const std::string l = line + "\n";
    if (!to_.valid() || ::write(to_.get(), l.data(), l.size()) != static_cast<ssize_t>(l.size())) return "ERROR write";
    return read_line(10000);
  }

  // Area memory as hex, e.g. get("DB", 1, 0, 4) -> "01020304".
  std::string get(const char* area, int db, int off, int len) {
    const std::string r = command(fmt::format("get {} {} {} {}", area, db, off, len));
    return r.rfind("OK ", 0) == 0 ? r.substr(3) : r;
  }
  void set(const char* area, int db, int off, const std::string& hex) {
    EXPECT_EQ(command(fmt::format("set {} {} {} {}", area, db, off, hex)), "OK");
  }

 private:
  std::string spawn(const std::string& dir) {
    int in[2];
    int out[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0) return "pipe failed";
    const std::string script = std::string(RTPLC_SOURCE_DIR) + "/io/drivers/s7/tests/snap7_server.js";
    const std::string node_path = dir + "/node_modules";
    const std::string port = std::to_string(port_);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(in[0], 0);
      ::dup2(out[1], 1);
      ::setenv("NODE_PATH", node_path.c_str(), 1);
      ::execlp("node", "node", script.c_str(), port.c_str(), static_cast<char*>(nullptr));
      const char msg[] = "ERROR cannot run node\n";
      [[maybe_unused]] const ssize_t n = ::write(1, msg, sizeof msg - 1);
      ::_exit(127);
    }
    ::close(in[0]);
    ::close(out[1]);
    to_.reset(in[1]);
    from_.reset(out[0]);
    const std::string ready = read_line(20000);
    if (ready.rfind("READY", 0) == 0) return {};
    return ready.empty() ? "snap7 server did not start" : ready;
  }

  std::string read_line(int timeout_ms) {
    while (true) {
      const size_t nl = buf_.find('\n');
      if (nl != std::string::npos) {
        std::string line = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        return line;
      }
      pollfd p{from_.get(), POLLIN, 0};
      if (::poll(&p, 1, timeout_ms) <= 0) return {};
      char tmp[4096];
      const ssize_t n = ::read(from_.get(), tmp, sizeof tmp);
      if (n <= 0) return {};
      buf_.append(tmp, static_cast<size_t>(n));
    }
  }

  pid_t pid_ = -1;
  uint16_t port_ = 0;
  UniqueFd to_;
  UniqueFd from_;
  std::string buf_;
};

class Snap7 : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string why = peer_.start();
    if (!why.empty()) GTEST_SKIP() << "snap7 peer unavailable: " << why;
    opt_.host = "127.0.0.1";
    opt_.port = peer_.port();
    opt_.connection.remote_tsap = remote_tsap(ConnectionType::kPG, 0, 2);
  }

  std::vector<ItemAddress> parse_all(std::initializer_list<const char*> texts) {
    std::vector<ItemAddress> out;
    for (const char* t : texts) out.push_back(*parse_address(t));
    return out;
  }

  Snap7Peer peer_;
  SessionOptions opt_;
};

TEST_F(Snap7, negotiates_pdu_and_amq_with_the_server) {
  Session s;
  auto r = s.connect(opt_);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(s.info().negotiated.pdu_size, 960);  // snap7 grants what we ask within [240, 4096]
  EXPECT_EQ(s.info().negotiated.amq_calling, 8);  // and echoes our AmQ
}

TEST_F(Snap7, reads_every_area_and_type_the_server_holds) {
  peer_.set("DB", 1, 0, "81");                // DBX0.0 and DBX0.7
  peer_.set("DB", 1, 2, "7f");                // DBB2
  peer_.set("DB", 1, 4, "fffe");              // DBW4 = 65534 / INT -2
  peer_.set("DB", 1, 8, "40490fdb");          // DBD8 = REAL pi
  peer_.set("DB", 1, 12, "00012345");         // DBD12
  peer_.set("MK", 0, 0, "02a55a");            // M0.1, MB1, MW1
  peer_.set("PE", 0, 0, "011234");            // I0.0, IW1
  peer_.set("PA", 0, 0, "02ff");              // Q0.1, QB1
  peer_.set("CT", 0, 0, "002a");              // C0
  peer_.set("TM", 0, 0, "1234");              // T0
  Session s;
  ASSERT_TRUE(s.connect(opt_).ok());
  const auto items = parse_all({"DB1.DBX0.0", "DB1.DBX0.7", "DB1.DBX0.1", "DB1.DBB2", "DB1.DBW4", "DB1.DBW4:INT",
                                "DB1.DBD8:REAL", "DB1.DBD12", "M0.1", "MB1", "MW1", "I0.0", "IW1", "Q0.1", "QB1", "C0",
                                "T0"});
  auto r = s.read(items);
  ASSERT_TRUE(r.ok()) << r.error();
  std::vector<std::string> got;
  for (size_t i = 0; i < items.size(); ++i) {
    ASSERT_TRUE((*r)[i].ok()) << format_address(items[i]) << ": " << item_error_message((*r)[i].return_code);
    got.push_back(format_value(items[i].type, (*r)[i].raw));
  }
  const std::vector<std::string> want = {"true", "true", "false", "127", "65534", "-2", "3.1415927", "74565", "true",
                                         "165", "42330", "true", "4660", "true", "255", "42", "4660"};
  EXPECT_EQ(got, want);
}

TEST_F(Snap7, writes_every_area_and_type_into_the_server) {
  Session s;
  ASSERT_TRUE(s.connect(opt_).ok());
  const auto items = parse_all({"DB1.DBX20.3", "DB1.DBB21", "DB1.DBW22:INT", "DB1.DBD24:REAL", "DB1.DBD28:DINT",
                                "M10.7", "MW12", "IB5", "I6.2", "QW8", "Q7.0", "C0", "T0"});
  const char* values[] = {"1", "200", "-1234", "2.5", "-100000", "true", "4660", "17", "1", "65535", "1", "999", "258"};
  std::vector<uint64_t> raws;
  for (size_t i = 0; i < items.size(); ++i) raws.push_back(*parse_value(items[i].type, values[i]));
  auto w = s.write(items, raws);
  ASSERT_TRUE(w.ok()) << w.error();
  for (size_t i = 0; i < items.size(); ++i) EXPECT_TRUE((*w)[i].ok()) << format_address(items[i]);
  EXPECT_EQ(peer_.get("DB", 1, 20, 12), "08c8fb2e40200000fffe7960");
  EXPECT_EQ(peer_.get("MK", 0, 10, 4), "80001234");
  EXPECT_EQ(peer_.get("PE", 0, 5, 2), "1104");
  EXPECT_EQ(peer_.get("PA", 0, 7, 3), "01ffff");
  EXPECT_EQ(peer_.get("CT", 0, 0, 2), "03e7");
  EXPECT_EQ(peer_.get("TM", 0, 0, 2), "0102");
  // And we read back what we wrote.
  auto r = s.read(items);
  ASSERT_TRUE(r.ok()) << r.error();
  for (size_t i = 0; i < items.size(); ++i) EXPECT_EQ((*r)[i].raw, raws[i]) << format_address(items[i]);
}

TEST_F(Snap7, reports_the_servers_item_errors) {
  Session s;
  ASSERT_TRUE(s.connect(opt_).ok());
  auto r = s.read(parse_all({"DB99.DBW0", "DB2.DBW100", "DB2.DBW0"}));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ((*r)[0].return_code, 0x0A);
  EXPECT_EQ((*r)[1].return_code, 0x05);
  EXPECT_TRUE((*r)[2].ok());
}

TEST_F(Snap7, accepts_explicit_tsaps_as_for_s7_200_and_logo) {
  opt_.connection.local_tsap = 0x1000;
  opt_.connection.remote_tsap = 0x2000;
  Session s;
  auto r = s.connect(opt_);
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_TRUE(s.read(parse_all({"MB0"})).ok());
}

TEST_F(Snap7, reads_many_items_across_several_pdus) {
  std::string hex;
  for (int i = 0; i < 512; ++i) hex += fmt::format("{:02x}", i & 0xFF);
  peer_.set("DB", 3, 0, hex);
  opt_.connection.setup.pdu_size = 240;
  Session s;
  ASSERT_TRUE(s.connect(opt_).ok());
  EXPECT_EQ(s.info().negotiated.pdu_size, 240);
  std::vector<ItemAddress> items;
  for (uint32_t k = 0; k < 250; ++k) {
    ItemAddress a;
    a.db = 3;
    a.start = k * 2;
    a.type = DataType::kWord;
    items.push_back(a);
  }
  auto r = s.read(items);
  ASSERT_TRUE(r.ok()) << r.error();
  for (uint32_t k = 0; k < 250; ++k) {
    const uint32_t b0 = (2 * k) & 0xFF;
    const uint32_t b1 = (2 * k + 1) & 0xFF;
    EXPECT_EQ((*r)[k].raw, b0 << 8 | b1) << k;
  }
}

TEST_F(Snap7, engine_polls_and_writes_the_server) {
  peer_.set("DB", 1, 40, "0064");
  Engine engine;
  PlcConfig cfg;
  cfg.address = "127.0.0.1";
  cfg.port = peer_.port();
  cfg.poll_period_ms = 50;
  auto plc = engine.connect(cfg);
  ASSERT_TRUE(plc.ok()) << plc.error();
  ItemConfig ic;
  ic.address = *parse_address("DB1.DBW40");
  ic.scale = 0.5;
  const ItemId w = *engine.add_item(*plc, ic);
  ic.address = *parse_address("M20.4");
  ic.scale = 1;
  const ItemId b = *engine.add_item(*plc, ic);
  ASSERT_TRUE(engine.start().ok());
  ASSERT_TRUE(testing::wait_for([&] { return engine.read(w).quality == Quality::kGood; }));
  EXPECT_EQ(engine.read(w).value, 50.0);
  peer_.set("DB", 1, 40, "00c8");
  ASSERT_TRUE(testing::wait_for([&] { return engine.read(w).value == 100.0; }));
  const WriteTicket t = engine.write(b, 1);
  ASSERT_TRUE(testing::wait_for([&] { return engine.write_result(t).state != WriteState::kPending; }));
  EXPECT_EQ(engine.write_result(t).state, WriteState::kAcknowledged);
  EXPECT_EQ(peer_.get("MK", 0, 20, 1), "10");
  ASSERT_TRUE(testing::wait_for([&] { return engine.read(b).value == 1.0; }));
  const PlcStatus st = engine.status(*plc);
  EXPECT_EQ(st.pdu_size, 960);
  EXPECT_EQ(st.errors, 0u);
}

}  // namespace
}  // namespace rtplc::s7
