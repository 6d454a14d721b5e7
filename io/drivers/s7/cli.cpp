// `rtplc s7 ...`: commissioning commands for Siemens S7 PLCs (issue 4, item 4) —
// read, write, info and poll against a real PLC, and fake-plc, which serves our fake
// PLC so the client can be tried without hardware. The S7 driver registers it
// (driver.cpp); this file only turns the command line into calls and results into lines.
#include <arpa/inet.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "io/drivers/s7/cli.h"

#include "common/exit_codes.h"
#include "io/drivers/s7/engine.h"
#include "io/drivers/s7/fake_plc.h"
#include "io/drivers/s7/session.h"

namespace rtplc::s7 {
namespace {

constexpr const char* kAddressHelp =
    "Addresses (case-insensitive, German E/A/Z accepted for I/Q/C):\n"
    "  DB1.DBX0.0  bit 0 of byte 0 of DB1     DB1.DBB2  byte     DB1.DBW4  word     DB1.DBD8  double word\n"
    "  MB0 MW2 MD4 M0.1   flags (merker)      IB0 IW0 I0.0   inputs      QB0 QW0 Q0.1   outputs\n"
    "  C0  counter 0      T0  timer 0 (raw S5TIME word)\n"
    "  Append :TYPE to reinterpret: DB1.DBD8:REAL  DB1.DBW4:INT  MD4:DINT  MB0:SINT  MB0:CHAR\n";

constexpr const char* kValueHelp =
    "Values (write, fake-plc --set) must fit the type, or nothing is written:\n"
    "  BOOL 1/0, true/false, on/off    BYTE 0..255    SINT -128..127    WORD, C, T 0..65535\n"
    "  INT -32768..32767    DWORD 0..4294967295    DINT -2147483648..2147483647\n"
    "  REAL a finite number within +-3.4028235e38 (e.g. 3.25, -1e3)\n"
    "  Whole numbers in decimal or hex (0x1F); hex is a number, so INT=0xFFFF is refused: write -1\n"
    "  CHAR one character (MB0:CHAR=A; MB0:CHAR=7 is the digit 7), or its code in hex (MB0:CHAR=0x0D)\n";

struct Target {
  std::string host;
  uint16_t port = 102;
  int rack = 0;
  int slot = 2;
  std::string conn_type = "pg";
  std::string tsap;  // "LOCAL:REMOTE" in hex, e.g. 1000:2000 for S7-200/LOGO
  int timeout_ms = 3000;
  int pdu = 960;
};

void add_target_options(CLI::App* cmd, Target& t) {
  cmd->add_option("HOST", t.host, "PLC address or host name")->required();
  cmd->add_option("--port", t.port, "ISO-on-TCP port")->default_val(102);
  cmd->add_option("--rack", t.rack, "rack of the CPU (S7-300/400/1200/1500)")->default_val(0)->check(CLI::Range(0, 7));
  cmd->add_option("--slot", t.slot, "slot of the CPU: 2 on an S7-300, 0 or 1 on an S7-1200/1500")
      ->default_val(2)
      ->check(CLI::Range(0, 31));
  cmd->add_option("--type", t.conn_type, "connection type for the rack/slot TSAP: pg, op or basic")
      ->default_val("pg")
      ->check(CLI::IsMember({"pg", "op", "basic"}, CLI::ignore_case));
  cmd->add_option("--tsap", t.tsap,
                  "explicit TSAPs LOCAL:REMOTE in hex instead of rack/slot (S7-200/LOGO: 1000:2000, 0100:0200)");
  cmd->add_option("--timeout", t.timeout_ms, "connect and reply timeout in ms (1..600000)")
      ->default_val(3000)
      ->check(CLI::Range(1, 600000));
  cmd->add_option("--pdu", t.pdu, "PDU size to ask for (the PLC may grant less)")->default_val(960)->check(
      CLI::Range(240, 4096));
}

[[noreturn]] void fail(int code, const std::string& msg) {
  std::fprintf(stderr, "rtplc s7: %s\n", msg.c_str());
  throw CLI::RuntimeError(code);
}

Result<SessionOptions> session_options(const Target& t) {
  SessionOptions o;
  o.host = t.host;
  o.port = t.port;
  o.connect_timeout_ms = t.timeout_ms;
  o.reply_timeout_ms = t.timeout_ms;
  o.connection.setup.pdu_size = static_cast<uint16_t>(t.pdu);
  if (!t.tsap.empty()) {
    unsigned local = 0;
    unsigned remote = 0;
    char extra = 0;
    if (std::sscanf(t.tsap.c_str(), "%x:%x%c", &local, &remote, &extra) != 2 || local > 0xFFFF || remote > 0xFFFF) {
      return make_error(fmt::format("--tsap '{}' must be LOCAL:REMOTE in hex, e.g. 1000:2000", t.tsap));
    }
    o.connection.local_tsap = static_cast<uint16_t>(local);
    o.connection.remote_tsap = static_cast<uint16_t>(remote);
  } else {
    std::string type = t.conn_type;
    std::transform(type.begin(), type.end(), type.begin(), [](unsigned char c) { return std::tolower(c); });
    const ConnectionType ct = type == "op" ? ConnectionType::kOP : type == "basic" ? ConnectionType::kBasic : ConnectionType::kPG;
    o.connection.remote_tsap = remote_tsap(ct, static_cast<unsigned>(t.rack), static_cast<unsigned>(t.slot));
  }
  return o;
}

std::vector<ItemAddress> parse_addresses(const std::vector<std::string>& texts) {
  std::vector<ItemAddress> out;
  std::string errors;
  for (const std::string& t : texts) {
    auto a = parse_address(t);
    if (a) {
      out.push_back(*a);
    } else {
      errors += (errors.empty() ? "" : "\nrtplc s7: ") + a.error();
    }
  }
  if (!errors.empty()) fail(kExitUsage, errors + "\n" + kAddressHelp);
  return out;
}

Session connect_or_fail(const Target& t) {
  auto opt = session_options(t);
  if (!opt) fail(kExitUsage, opt.error());
  Session s;
  if (auto r = s.connect(*opt); !r) fail(kExitFailure, r.error());
  return s;
}

void run_read(const Target& t, const std::vector<std::string>& texts) {
  const auto items = parse_addresses(texts);
  Session s = connect_or_fail(t);
  auto r = s.read(items);
  if (!r) fail(kExitFailure, r.error());
  bool all_ok = true;
  for (size_t i = 0; i < items.size(); ++i) {
    if ((*r)[i].ok()) {
      std::printf("%s = %s\n", texts[i].c_str(), format_value(items[i].type, (*r)[i].raw).c_str());
    } else {
      all_ok = false;
      std::fprintf(stderr, "rtplc s7: %s: %s\n", texts[i].c_str(), item_error_message((*r)[i].return_code).c_str());
    }
  }
  std::fflush(stdout);
  if (!all_ok) throw CLI::RuntimeError(kExitFailure);
}

void run_write(const Target& t, const std::vector<std::string>& assignments) {
  std::vector<std::string> names;
  std::vector<std::string> values;
  for (const std::string& a : assignments) {
    const size_t eq = a.find('=');
    if (eq == std::string::npos) fail(kExitUsage, fmt::format("'{}' is not ADDR=VALUE (e.g. DB1.DBW4=12)", a));
    names.push_back(a.substr(0, eq));
    values.push_back(a.substr(eq + 1));
  }
  const auto items = parse_addresses(names);
  std::vector<uint64_t> raws;
  for (size_t i = 0; i < items.size(); ++i) {
    // Every value is checked against its item's type before anything is sent:
    // nothing reaches the PLC when one of them is wrong.
    auto v = encode_value(items[i], values[i]);
    if (!v) fail(kExitUsage, v.error());
    raws.push_back(*v);
  }
  Session s = connect_or_fail(t);
  auto r = s.write(items, raws);
  if (!r) fail(kExitFailure, r.error());
  bool all_ok = true;
  for (size_t i = 0; i < items.size(); ++i) {
    if ((*r)[i].ok()) {
      std::printf("%s = %s\n", names[i].c_str(), format_value(items[i].type, raws[i]).c_str());
    } else {
      all_ok = false;
      std::fprintf(stderr, "rtplc s7: %s: write refused: %s\n", names[i].c_str(),
                   item_error_message((*r)[i].return_code).c_str());
    }
  }
  std::fflush(stdout);
  if (!all_ok) throw CLI::RuntimeError(kExitFailure);
}

void run_info(const Target& t, int pings) {
  auto opt = session_options(t);
  if (!opt) fail(kExitUsage, opt.error());
  Session s = connect_or_fail(t);
  const SessionInfo& info = s.info();
  std::vector<double> rtt;
  for (int i = 0; i < pings; ++i) {
    auto ms = s.ping_ms();
    if (!ms) fail(kExitFailure, ms.error());
    rtt.push_back(*ms);
  }
  std::sort(rtt.begin(), rtt.end());
  std::printf("endpoint        = %s\n", info.endpoint.text().c_str());
  std::printf("tsap            = %04X -> %04X\n", opt->connection.local_tsap, opt->connection.remote_tsap);
  std::printf("pdu             = %u (asked %d)\n", info.negotiated.pdu_size, t.pdu);
  std::printf("amq             = %u calling, %u called\n", info.negotiated.amq_calling, info.negotiated.amq_called);
  std::printf("tcp_connect_ms  = %.2f\n", info.tcp_connect_ms);
  std::printf("handshake_ms    = %.2f (COTP + setup)\n", info.setup_ms);
  if (!rtt.empty()) {
    std::printf("rtt_ms          = min %.2f / p50 %.2f / max %.2f over %d reads of MB0\n", rtt.front(),
                rtt[rtt.size() / 2], rtt.back(), pings);
  }
  std::fflush(stdout);
}

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

void run_poll(const Target& t, const std::vector<std::string>& texts, int period_ms, double seconds) {
  const auto items = parse_addresses(texts);
  auto opt = session_options(t);
  if (!opt) fail(kExitUsage, opt.error());
  auto ep = resolve_endpoint(t.host, t.port);
  if (!ep) fail(kExitFailure, ep.error());
  Engine engine;
  PlcConfig cfg;
  cfg.address = ep->text().substr(0, ep->text().rfind(':'));
  cfg.port = t.port;
  cfg.connection = opt->connection;
  cfg.poll_period_ms = static_cast<uint32_t>(period_ms);
  cfg.reply_timeout_ms = static_cast<uint32_t>(t.timeout_ms);
  auto plc = engine.connect(cfg);
  if (!plc) fail(kExitFailure, plc.error());
  std::vector<ItemId> ids;
  for (const ItemAddress& a : items) {
    ItemConfig ic;
    ic.address = a;
    auto id = engine.add_item(*plc, ic);
    if (!id) fail(kExitFailure, id.error());
    ids.push_back(*id);
  }
  if (auto r = engine.start(); !r) fail(kExitFailure, r.error());
  ::signal(SIGINT, on_signal);
  ::signal(SIGTERM, on_signal);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!g_stop && (seconds <= 0 || std::chrono::steady_clock::now() < end)) {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    const PlcStatus st = engine.status(*plc);
    const int64_t now = Engine::now_ns();
    for (size_t i = 0; i < ids.size(); ++i) {
      const Sample smp = engine.read(ids[i]);
      const Quality q = smp.quality_at(now);
      const char* qn = q == Quality::kGood ? "good" : q == Quality::kStale ? "stale" : "bad";
      std::printf("%s = %s (%s)\n", texts[i].c_str(), format_value(items[i].type, smp.raw).c_str(), qn);
    }
    std::printf("# %s pdu=%u amq=%u polls=%llu missed=%llu rtt_p50=%.2fms rtt_p99=%.2fms timeouts=%llu "
                "reconnects=%llu errors=%llu%s%s\n",
                std::string(plc_state_name(st.state)).c_str(), st.pdu_size, st.amq,
                static_cast<unsigned long long>(st.polls_completed), static_cast<unsigned long long>(st.polls_missed),
                st.rtt_p50_us / 1000.0, st.rtt_p99_us / 1000.0, static_cast<unsigned long long>(st.timeouts),
                static_cast<unsigned long long>(st.reconnects), static_cast<unsigned long long>(st.errors),
                st.last_error[0] != '\0' ? " last_error=" : "", st.last_error);
    std::fflush(stdout);
  }
  engine.stop();
}

struct FakeOptions {
  std::string listen = "127.0.0.1";
  uint16_t port = 102;
  int count = 1;
  std::string delay = "0";
  int jitter_ms = 0;
  double blackhole_pct = 0;
  int pdu = 480;
  int amq = 8;
  std::vector<std::string> sets;
};

void run_fake(const FakeOptions& f) {
  uint32_t dmin = 0;
  uint32_t dmax = 0;
  char extra = 0;
  const int n = std::sscanf(f.delay.c_str(), "%u-%u%c", &dmin, &dmax, &extra);
  if (n == 1) dmax = dmin;
  if (n < 1 || n > 2 || dmax < dmin) fail(kExitUsage, fmt::format("--delay '{}' must be MS or MIN-MAX", f.delay));
  auto base = parse_endpoint(f.listen, f.port);
  if (!base) fail(kExitUsage, base.error());
  raise_fd_limit(static_cast<size_t>(f.count) * 4 + 64);
  FakePlc fake;
  const uint32_t first = ntohl(base->addr.sin_addr.s_addr);
  for (int i = 0; i < f.count; ++i) {
    FakeEndpointSpec spec;
    const uint32_t ip = first + static_cast<uint32_t>(i);
    spec.address = fmt::format("{}.{}.{}.{}", ip >> 24, (ip >> 16) & 0xFF, (ip >> 8) & 0xFF, ip & 0xFF);
    spec.port = f.port;
    spec.behavior.delay_us = (dmin + (dmax > dmin ? static_cast<uint32_t>(i * 7919) % (dmax - dmin + 1) : 0)) * 1000;
    spec.behavior.jitter_us = static_cast<uint32_t>(f.jitter_ms) * 1000;
    spec.behavior.max_pdu = static_cast<uint16_t>(f.pdu);
    spec.behavior.max_amq = static_cast<uint16_t>(f.amq);
    // The first N of every hundred PLCs, so any count gets its share.
    const bool dead = static_cast<double>(i % 100) < f.blackhole_pct;
    if (dead) spec.behavior.blackhole = FakeBehavior::Blackhole::kNeverAccept;
    auto ep = fake.add_endpoint(spec);
    if (!ep) fail(kExitFailure, ep.error());
    for (const std::string& s : f.sets) {
      const size_t eq = s.find('=');
      auto a = eq == std::string::npos ? Result<ItemAddress>(make_error("")) : parse_address(s.substr(0, eq));
      if (!a) fail(kExitUsage, fmt::format("--set '{}' must be ADDR=VALUE: {}", s, a.error()));
      auto v = encode_value(*a, s.substr(eq + 1));
      if (!v) fail(kExitUsage, fmt::format("--set '{}': {}", s, v.error()));
      if (a->type == DataType::kBool) {
        Bytes cur = fake.read_memory(*ep, a->area, a->db, a->start, 1);
        if (cur.empty()) fail(kExitUsage, fmt::format("--set '{}': outside the fake's memory", s));
        cur[0] = static_cast<uint8_t>(*v ? (cur[0] | (1u << a->bit)) : (cur[0] & ~(1u << a->bit)));
        fake.write_memory(*ep, a->area, a->db, a->start, cur);
      } else {
        uint8_t buf[4] = {};
        encode_raw(a->type, *v, std::span<uint8_t>(buf, type_size(a->type)));
        fake.write_memory(*ep, a->area, a->db, a->start, ByteSpan(buf, type_size(a->type)));
      }
    }
    if (i < 3 || i == f.count - 1) {
      std::printf("fake PLC %d on %s:%u delay %u ms%s\n", i, spec.address.c_str(), fake.port(*ep),
                  spec.behavior.delay_us / 1000, dead ? " (blackholed: never accepts)" : "");
    } else if (i == 3) {
      std::printf("...\n");
    }
  }
  std::printf("serving %d fake PLC(s) with DB1..DB16, I, Q, M of 1024 bytes, counters and timers; Ctrl-C stops\n",
              f.count);
  std::fflush(stdout);
  ::signal(SIGINT, on_signal);
  ::signal(SIGTERM, on_signal);
  fake.run(g_stop);
}

}  // namespace

void add_commands(CLI::App& app) {
  CLI::App* s7 = app.add_subcommand(
      "s7", "Talk to Siemens S7 PLCs over ISO-on-TCP: read, write, info, poll, fake-plc");
  s7->require_subcommand(1);
  s7->footer(std::string("\n") + kAddressHelp + kValueHelp +
             "\nExamples:\n"
             "  rtplc s7 read 192.168.0.10 DB1.DBW4 DB1.DBD8:REAL M0.1\n"
             "  rtplc s7 write 192.168.0.10 DB1.DBW4=12 Q0.1=1 --slot 1\n"
             "  rtplc s7 info 192.168.0.10 --tsap 1000:2000        # LOGO!/S7-200\n"
             "  rtplc s7 fake-plc --port 10102 & rtplc s7 read 127.0.0.1 --port 10102 MW0\n");

  static Target read_t;
  static std::vector<std::string> read_addrs;
  CLI::App* read = s7->add_subcommand("read", "Read items and print them one per line as ADDR = VALUE");
  add_target_options(read, read_t);
  read->add_option("ADDR", read_addrs, "items to read (see `rtplc s7 --help` for the syntax)")->required();
  read->callback([] { run_read(read_t, read_addrs); });

  static Target write_t;
  static std::vector<std::string> write_items;
  CLI::App* write = s7->add_subcommand("write", "Write items given as ADDR=VALUE; prints what was written");
  add_target_options(write, write_t);
  write->add_option("ADDR=VALUE", write_items, "e.g. DB1.DBW4=12 DB1.DBD8:REAL=3.5 M0.1=true MB0:CHAR=A")->required();
  write->footer(std::string("\n") + kValueHelp + "Exit code 2 (nothing sent) when a value does not fit its type.\n");
  write->callback([] { run_write(write_t, write_items); });

  static Target info_t;
  static int pings = 10;
  CLI::App* info = s7->add_subcommand("info", "Connect and show the negotiated PDU size, AmQ and round-trip times");
  add_target_options(info, info_t);
  info->add_option("--pings", pings, "reads of MB0 to time")->default_val(10)->check(CLI::Range(0, 10000));
  info->callback([] { run_info(info_t, pings); });

  static Target poll_t;
  static std::vector<std::string> poll_addrs;
  static int period = 100;
  static double seconds = 0;
  CLI::App* poll = s7->add_subcommand(
      "poll", "Poll items with the runtime's engine; prints values with quality and the link statistics every second");
  add_target_options(poll, poll_t);
  poll->add_option("ADDR", poll_addrs, "items to poll")->required();
  poll->add_option("--period", period, "poll period in ms")->default_val(100)->check(CLI::Range(1, 3600000));
  poll->add_option("--duration", seconds, "stop after this many seconds (0: until Ctrl-C)")->default_val(0);
  poll->callback([] { run_poll(poll_t, poll_addrs, period, seconds); });

  static FakeOptions fake_o;
  CLI::App* fake = s7->add_subcommand(
      "fake-plc", "Serve fake S7 PLCs (for trying the client without hardware, and for load tests)");
  fake->add_option("--listen", fake_o.listen, "first address; more PLCs take the next addresses (127.0.0.0/8)")
      ->default_val("127.0.0.1");
  fake->add_option("--port", fake_o.port, "port of every fake PLC (102 needs root)")->default_val(102);
  fake->add_option("--count", fake_o.count, "number of PLCs")->default_val(1)->check(CLI::Range(1, 100000));
  fake->add_option("--delay", fake_o.delay, "reply delay in ms, or MIN-MAX spread over the PLCs")->default_val("0");
  fake->add_option("--jitter", fake_o.jitter_ms, "extra random delay per reply, ms")->default_val(0);
  fake->add_option("--blackhole", fake_o.blackhole_pct, "percent of PLCs that never accept a connection")
      ->default_val(0)
      ->check(CLI::Range(0.0, 100.0));
  fake->add_option("--pdu", fake_o.pdu, "largest PDU granted")->default_val(480)->check(CLI::Range(64, 4096));
  fake->add_option("--amq", fake_o.amq, "most parallel jobs granted")->default_val(8)->check(CLI::Range(1, 32));
  fake->add_option("--set", fake_o.sets, "initial value in every PLC, ADDR=VALUE (repeatable)");
  fake->callback([] { run_fake(fake_o); });
}

}  // namespace rtplc::s7
