// The modbus-server's answers (requests.h), without a network: reads of
// pairs, scaled and bit items, the exceptions for what is not exposed, not
// good or does not fit, writes that reach the set-point writer whole or not at
// all; then the TCP side (server.h) on loopback: the allow-list, max_clients,
// silent clients, many clients at once.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <thread>

#include "config/config.h"
#include "io/drivers/modbus/pdu.h"
#include "io/drivers/modbus_server/requests.h"
#include "io/drivers/modbus_server/server.h"
#include "tests/support/eventually.h"

namespace rtplc::modbus_server {
namespace {

using Bytes = std::vector<uint8_t>;

ServerSettings settings_from(const std::string& expose, const std::string& extra = "") {
  auto r = config::parse_config("tasks:\n  - {name: t, program: p.fbd}\ndrivers:\n  - kind: modbus-server\n" + extra +
                                    "    expose:\n" + expose,
                                "c.yaml", "", config::LoadOptions{false});
  EXPECT_TRUE(r.ok()) << r.render();
  return r.ok() ? settings_of(r.config->drivers[0]) : ServerSettings{};
}

const char* kItems =
    "      - {label: ProcVal, table: ir, address: 0, type: f32}\n"                // 0
    "      - {label: ManiVal, table: ir, address: 2, type: f32, word_order: low_first}\n"  // 1
    "      - {label: Setpoint, table: hr, address: 0, type: f32}\n"              // 2 (set-point)
    "      - {label: Level, table: hr, address: 10, type: i16, scale: 0.1}\n"    // 3 (an input)
    "      - {label: Count, table: hr, address: 11, scale: 0.5, offset: 10}\n"   // 4 (set-point)
    "      - {label: Run, table: coil, address: 0}\n"                            // 5 (set-point)
    "      - {label: Lamp, table: di, address: 0}\n";                            // 6 (an output)

Bytes read_pdu(uint8_t fc, uint16_t addr, uint16_t count) {
  return {fc, static_cast<uint8_t>(addr >> 8), static_cast<uint8_t>(addr), static_cast<uint8_t>(count >> 8),
          static_cast<uint8_t>(count)};
}
Bytes write16_pdu(uint16_t addr, const std::vector<uint16_t>& words) {
  Bytes p = read_pdu(16, addr, static_cast<uint16_t>(words.size()));
  p.push_back(static_cast<uint8_t>(words.size() * 2));
  for (uint16_t w : words) {
    p.push_back(static_cast<uint8_t>(w >> 8));
    p.push_back(static_cast<uint8_t>(w));
  }
  return p;
}
uint16_t word(const Bytes& reply, size_t i) { return static_cast<uint16_t>(reply[2 + 2 * i] << 8 | reply[3 + 2 * i]); }

std::pair<uint16_t, uint16_t> f32_words(float f) {
  uint32_t raw;
  std::memcpy(&raw, &f, sizeof raw);
  return {static_cast<uint16_t>(raw >> 16), static_cast<uint16_t>(raw)};
}

class Requests : public ::testing::Test {
 protected:
  Requests()
      : s_(settings_from(kItems)),
        values_{{42.5, Quality::kGood}, {-3.25, Quality::kGood}, {50, Quality::kGood}, {12.34, Quality::kGood},
                {20, Quality::kGood},   {1, Quality::kGood},     {0, Quality::kGood}},
        handler_(s_, {false, false, true, false, true, true, false},
                 [this](uint32_t i) { return values_[i]; },
                 [this](uint32_t i, double v) -> Result<std::string> {
                   if (!refusal_.empty()) return make_error(refusal_);
                   writes_.emplace_back(i, v);
                   values_[i].value = v;
                   return s_.items[i].label + " = " + std::to_string(v);
                 }) {}

  Bytes ask(const Bytes& pdu) {
    out_ = Outcome{};
    return handler_.answer(pdu.data(), pdu.size(), out_);
  }
  static Bytes exception(uint8_t fc, uint8_t code) { return {static_cast<uint8_t>(fc | 0x80), code}; }

  ServerSettings s_;
  std::vector<ItemReading> values_;
  std::vector<std::pair<uint32_t, double>> writes_;
  std::string refusal_;
  RequestHandler handler_;
  Outcome out_;
};

TEST_F(Requests, reads_f32_pairs_in_their_word_order) {
  const Bytes r = ask(read_pdu(4, 0, 4));
  ASSERT_EQ(r.size(), 2u + 8u);
  EXPECT_EQ(r[0], 4);
  EXPECT_EQ(r[1], 8);
  EXPECT_EQ(word(r, 0), f32_words(42.5f).first);  // high word first
  EXPECT_EQ(word(r, 1), f32_words(42.5f).second);
  EXPECT_EQ(word(r, 2), f32_words(-3.25f).second);  // low_first
  EXPECT_EQ(word(r, 3), f32_words(-3.25f).first);
  EXPECT_EQ(out_.exception, 0);
}

TEST_F(Requests, reads_scaled_integers_rounded_to_the_nearest_raw_value) {
  Bytes r = ask(read_pdu(3, 10, 2));
  EXPECT_EQ(word(r, 0), 123);  // 12.34 / 0.1
  EXPECT_EQ(word(r, 1), 20);   // (20 - 10) / 0.5
  values_[3].value = -1.26;
  r = ask(read_pdu(3, 10, 1));
  EXPECT_EQ(word(r, 0), static_cast<uint16_t>(-13));
}

TEST_F(Requests, reads_bits_of_digital_channels) {
  values_[5].value = 1;
  EXPECT_EQ(ask(read_pdu(1, 0, 1)), (Bytes{1, 1, 1}));
  values_[6].value = 1;
  EXPECT_EQ(ask(read_pdu(2, 0, 1)), (Bytes{2, 1, 1}));
}

TEST_F(Requests, a_read_of_an_address_not_exposed_is_exception_2) {
  EXPECT_EQ(ask(read_pdu(4, 0, 5)), exception(4, 2));  // ir 4 is not exposed
  EXPECT_EQ(ask(read_pdu(3, 2, 1)), exception(3, 2));
  EXPECT_EQ(ask(read_pdu(4, 10, 1)), exception(4, 2));  // hr 10 is exposed, ir 10 is not
  EXPECT_EQ(out_.exception, 2);
}

TEST_F(Requests, a_read_covering_a_channel_not_good_is_exception_4) {
  values_[1].quality = Quality::kBad;
  EXPECT_EQ(ask(read_pdu(4, 0, 4)), exception(4, 4));
  EXPECT_EQ(ask(read_pdu(4, 0, 2)).size(), 6u);  // ProcVal alone is still served
  values_[1].quality = Quality::kStale;
  EXPECT_EQ(ask(read_pdu(4, 2, 2)), exception(4, 4));
  values_[1].quality = Quality::kForced;  // the operator's word counts as good
  EXPECT_EQ(ask(read_pdu(4, 2, 2)).size(), 6u);
}

TEST_F(Requests, a_value_that_does_not_fit_its_item_is_exception_4_never_a_clipped_number) {
  values_[4].value = 40000;  // (40000 - 10) / 0.5 > 65535
  EXPECT_EQ(ask(read_pdu(3, 11, 1)), exception(3, 4));
  values_[4].value = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ask(read_pdu(3, 11, 1)), exception(3, 4));
  values_[0].value = std::numeric_limits<double>::infinity();
  EXPECT_EQ(ask(read_pdu(4, 0, 2)), exception(4, 4));
}

TEST_F(Requests, a_set_point_pair_written_with_fc16_reaches_the_writer) {
  const auto [hi, lo] = f32_words(55.5f);
  const Bytes pdu = write16_pdu(0, {hi, lo});
  EXPECT_EQ(ask(pdu), Bytes(pdu.begin(), pdu.begin() + 5));
  ASSERT_EQ(writes_.size(), 1u);
  EXPECT_EQ(writes_[0], std::make_pair(2u, 55.5));
  EXPECT_EQ(out_.written, 1u);
  ASSERT_EQ(out_.log.size(), 1u);
  // Read back through the handler: the same words.
  const Bytes r = ask(read_pdu(3, 0, 2));
  EXPECT_EQ(word(r, 0), hi);
  EXPECT_EQ(word(r, 1), lo);
}

TEST_F(Requests, a_scaled_set_point_written_with_fc6_is_converted_back) {
  const Bytes pdu = {6, 0, 11, 0, 30};  // raw 30 -> 30 * 0.5 + 10
  EXPECT_EQ(ask(pdu), pdu);
  ASSERT_EQ(writes_.size(), 1u);
  EXPECT_EQ(writes_[0], std::make_pair(4u, 25.0));
}

TEST_F(Requests, a_write_of_half_a_pair_is_exception_3_and_writes_nothing) {
  EXPECT_EQ(ask({6, 0, 0, 0x42, 0x5C}), exception(6, 3));
  EXPECT_EQ(ask(write16_pdu(1, {0})), exception(16, 3));
  EXPECT_TRUE(writes_.empty());
}

TEST_F(Requests, a_write_to_an_input_an_output_or_nothing_is_exception_2_and_writes_nothing) {
  EXPECT_EQ(ask({6, 0, 10, 0, 1}), exception(6, 2));   // Level is an input
  EXPECT_EQ(ask({5, 0, 1, 0xFF, 0}), exception(5, 2)); // coil 1 is not exposed
  EXPECT_EQ(ask({6, 0, 20, 0, 1}), exception(6, 2));
  // Setpoint and Level in one request: refused whole, Setpoint untouched.
  const auto [hi, lo] = f32_words(1.0f);
  EXPECT_EQ(ask(write16_pdu(0, {hi, lo, 0, 0, 0, 0, 0, 0, 0, 0, 7})), exception(16, 2));
  EXPECT_TRUE(writes_.empty());
}

TEST_F(Requests, a_non_finite_float_is_exception_3) {
  EXPECT_EQ(ask(write16_pdu(0, {0x7FC0, 0})), exception(16, 3));  // NaN
  EXPECT_EQ(ask(write16_pdu(0, {0x7F80, 0})), exception(16, 3));  // +inf
  EXPECT_TRUE(writes_.empty());
}

TEST_F(Requests, a_value_the_runtime_refuses_is_exception_3_and_a_failed_retain_exception_4) {
  refusal_ = "Setpoint must be 0..100";
  const auto [hi, lo] = f32_words(500.0f);
  EXPECT_EQ(ask(write16_pdu(0, {hi, lo})), exception(16, 3));
  EXPECT_TRUE(out_.write_refused);
  ASSERT_EQ(out_.log.size(), 1u);
  EXPECT_NE(out_.log[0].find("refused: Setpoint must be 0..100"), std::string::npos) << out_.log[0];
  refusal_ = "not changed: cannot retain it: disk full";
  EXPECT_EQ(ask(write16_pdu(0, {hi, lo})), exception(16, 4));
}

TEST_F(Requests, coils_of_digital_set_points_are_written_with_fc5_and_fc15) {
  EXPECT_EQ(ask({5, 0, 0, 0, 0}), (Bytes{5, 0, 0, 0, 0}));
  EXPECT_EQ(ask({15, 0, 0, 0, 1, 1, 1}), (Bytes{15, 0, 0, 0, 1}));
  ASSERT_EQ(writes_.size(), 2u);
  EXPECT_EQ(writes_[0], std::make_pair(5u, 0.0));
  EXPECT_EQ(writes_[1], std::make_pair(5u, 1.0));
}

TEST_F(Requests, malformed_requests_get_the_exceptions_the_specification_names) {
  EXPECT_EQ(ask({8, 0, 0, 0, 0}), exception(8, 1));          // diagnostics: not served
  EXPECT_EQ(ask(read_pdu(3, 0, 0)), exception(3, 3));        // quantity 0
  EXPECT_EQ(ask(read_pdu(3, 0, 126)), exception(3, 3));      // more than 125 registers
  EXPECT_EQ(ask(read_pdu(3, 65535, 2)), exception(3, 2));    // past the last address
  EXPECT_EQ(ask({16, 0, 0, 0, 1, 4, 0, 0}), exception(16, 3)); // byte count does not match
  EXPECT_EQ(ask({5, 0, 0, 0x12, 0x34}), exception(5, 3));    // a coil is FF00 or 0000
  EXPECT_TRUE(writes_.empty());
}

// ---- TCP -------------------------------------------------------------------

int connect_to(uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// One request, its reply PDU; empty when the server closed or said nothing
// within 10 s (a generous bound on a shared machine; no test asserts a time).
Bytes exchange(int fd, uint16_t tid, uint8_t unit, const Bytes& pdu) {
  Bytes frame;
  modbus::append_frame(frame, tid, unit, pdu.data(), pdu.size());
  if (::send(fd, frame.data(), frame.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(frame.size())) return {};
  Bytes in;
  for (;;) {
    modbus::Frame f;
    if (modbus::next_frame(in.data(), in.size(), f) == modbus::FrameStatus::kComplete) {
      EXPECT_EQ(f.transaction, tid);
      return Bytes(f.pdu, f.pdu + f.pdu_len);
    }
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 10000) <= 0) return {};
    uint8_t buf[512];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) return {};
    in.insert(in.end(), buf, buf + n);
  }
}

// True when the server closed `fd` (within 10 s).
bool closed_by_server(int fd) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, 10000) <= 0) return false;
  uint8_t b;
  return ::recv(fd, &b, 1, 0) == 0;
}

using rtplc::testing::eventually;

struct Served {
  explicit Served(const std::string& extra)
      : s(settings_from("      - {label: ProcVal, table: ir, address: 0, type: f32}\n", "    port: 1\n" + extra)),
        handler(s, {false}, [](uint32_t) { return ItemReading{21.5, Quality::kGood}; },
                [](uint32_t, double) -> Result<std::string> { return make_error("no"); }),
        server(s, handler, [this](bool, const std::string& line) {
          std::lock_guard lock(mu);
          log.push_back(line);
        }) {
    s.port = 0;  // any free port
    EXPECT_TRUE(server.start("mbs-test", 0, -1).ok());
  }
  // The server's thread logs into these until the server stops: declared
  // before it, so they are destroyed after it.
  std::mutex mu;
  std::vector<std::string> log;
  ServerSettings s;
  RequestHandler handler;
  TcpServer server;
};

TEST(TcpServer, answers_a_client_and_refuses_units_it_does_not_serve) {
  Served sv("    units: [1]\n");
  const int fd = connect_to(sv.server.port());
  ASSERT_GE(fd, 0);
  const Bytes r = exchange(fd, 7, 1, read_pdu(4, 0, 2));
  ASSERT_EQ(r.size(), 6u);
  EXPECT_EQ(word(r, 0), f32_words(21.5f).first);
  EXPECT_EQ(exchange(fd, 8, 2, read_pdu(4, 0, 2)), (Bytes{0x84, 11}));
  ::close(fd);
  EXPECT_TRUE(eventually([&] { return sv.server.counters().requests.load() == 2; }));
  EXPECT_EQ(sv.server.counters().exceptions.load(), 1u);
}

TEST(TcpServer, a_client_outside_the_allow_list_is_disconnected_counted_and_logged) {
  Served sv("    allow: [10.0.0.0/8]\n");
  const int fd = connect_to(sv.server.port());
  ASSERT_GE(fd, 0);
  EXPECT_TRUE(closed_by_server(fd));
  ::close(fd);
  EXPECT_TRUE(eventually([&] { return sv.server.counters().refused.load() == 1; }));
  EXPECT_EQ(sv.server.counters().accepted.load(), 0u);
  std::lock_guard lock(sv.mu);
  ASSERT_FALSE(sv.log.empty());
  EXPECT_NE(sv.log[0].find("refused: not in 'allow'"), std::string::npos) << sv.log[0];
}

TEST(TcpServer, one_client_beyond_max_clients_is_refused_the_others_served) {
  Served sv("    max_clients: 2\n");
  const int a = connect_to(sv.server.port());
  const int b = connect_to(sv.server.port());
  ASSERT_EQ(exchange(a, 1, 1, read_pdu(4, 0, 2)).size(), 6u);
  ASSERT_EQ(exchange(b, 1, 1, read_pdu(4, 0, 2)).size(), 6u);
  const int c = connect_to(sv.server.port());
  EXPECT_TRUE(closed_by_server(c));
  EXPECT_EQ(exchange(a, 2, 1, read_pdu(4, 0, 2)).size(), 6u);
  EXPECT_TRUE(eventually([&] { return sv.server.counters().refused.load() == 1; }));
  for (int fd : {a, b, c}) ::close(fd);
}

TEST(TcpServer, a_silent_client_is_disconnected_after_the_timeout) {
  Served sv("    timeout: 100ms\n");
  const int fd = connect_to(sv.server.port());
  EXPECT_TRUE(closed_by_server(fd));
  ::close(fd);
  EXPECT_TRUE(eventually([&] { return sv.server.counters().idle_closed.load() == 1; }));
}

TEST(TcpServer, a_stream_that_is_not_modbus_is_hung_up_on) {
  Served sv("");
  const int fd = connect_to(sv.server.port());
  const char junk[] = "GET / HTTP/1.0\r\n\r\n";
  ASSERT_EQ(::send(fd, junk, sizeof junk - 1, MSG_NOSIGNAL), static_cast<ssize_t>(sizeof junk - 1));
  EXPECT_TRUE(closed_by_server(fd));
  ::close(fd);
  EXPECT_TRUE(eventually([&] { return sv.server.counters().bad_frames.load() == 1; }));
}

TEST(TcpServer, many_clients_at_once_each_get_their_own_answers) {
  Served sv("    max_clients: 40\n");
  std::vector<int> fds;
  for (int i = 0; i < 32; ++i) {
    fds.push_back(connect_to(sv.server.port()));
    ASSERT_GE(fds.back(), 0);
  }
  // Every client sends before any reads, so the server has 32 requests in flight.
  for (size_t i = 0; i < fds.size(); ++i) {
    Bytes frame;
    const Bytes pdu = read_pdu(4, 0, 2);
    modbus::append_frame(frame, static_cast<uint16_t>(100 + i), 1, pdu.data(), pdu.size());
    ASSERT_EQ(::send(fds[i], frame.data(), frame.size(), MSG_NOSIGNAL), static_cast<ssize_t>(frame.size()));
  }
  for (size_t i = 0; i < fds.size(); ++i) {
    uint8_t buf[64];
    size_t got = 0;
    while (got < 13) {
      pollfd p{fds[i], POLLIN, 0};
      ASSERT_GT(::poll(&p, 1, 10000), 0);
      const ssize_t n = ::recv(fds[i], buf + got, sizeof buf - got, 0);
      ASSERT_GT(n, 0);
      got += static_cast<size_t>(n);
    }
    EXPECT_EQ(got, 13u);  // 7 MBAP + FC + count + 4
    EXPECT_EQ(buf[0] << 8 | buf[1], static_cast<int>(100 + i));
  }
  EXPECT_TRUE(eventually([&] { return sv.server.counters().connected.load() == 32; }));
  for (int fd : fds) ::close(fd);
  EXPECT_TRUE(eventually([&] { return sv.server.counters().connected.load() == 0; }));
  EXPECT_EQ(sv.server.counters().requests.load(), 32u);
}

}  // namespace
}  // namespace rtplc::modbus_server
