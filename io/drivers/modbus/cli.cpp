// `rtplc modbus ...`: commissioning commands for Modbus slaves (issue 9, item 3)
// — read, write and scan against a slave over TCP or RTU, and fake-slave, which
// serves our fault-injecting slave so the master can be tried without hardware.
// The modbus driver registers it (driver.cpp); this file turns the command line
// into requests and outcomes into lines.
#include <signal.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "io/drivers/modbus/cli.h"

#include "common/exit_codes.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"

namespace rtplc::modbus {
namespace {

constexpr const char* kAddressHelp =
    "Addresses (N = the 0-based protocol address):\n"
    "  coil:N  coil (read/write bit)        di:N  discrete input (read-only bit)\n"
    "  hr:N[:TYPE]  holding register        ir:N[:TYPE]  input register (read-only)\n"
    "  TYPE: u16 (default), i16, u32, i32, f32. Two-register types (u32, i32, f32) are\n"
    "  high word first; append :swapped for low word first: hr:4:f32:swapped\n"
    "  write takes ADDRESS=VALUE: hr:20=513 coil:21=1 hr:22:f32=1.5\n";

struct Target {
  std::vector<std::string> args;  // HOST then items (TCP), or only items (--rtu)
  uint16_t port = 502;
  int unit = 1;
  std::string rtu;
  uint32_t baud = 19200;
  std::string parity = "E";
  int data_bits = 8;
  int stop_bits = 1;
  int timeout_ms = 1000;
};

void add_target_options(CLI::App* cmd, Target& t, const char* what) {
  cmd->add_option("ARGS", t.args, what);
  cmd->add_option("--port", t.port, "Modbus TCP port")->default_val(502);
  cmd->add_option("--unit", t.unit, "unit (slave) id")->default_val(1)->check(CLI::Range(0, 247));
  cmd->add_option("--rtu", t.rtu, "Modbus RTU on this serial device instead of TCP (no HOST then)");
  cmd->add_option("--baud", t.baud, "RTU bits per second")->default_val(19200);
  cmd->add_option("--parity", t.parity, "RTU parity: N, E or O")->default_val("E")->check(CLI::IsMember({"N", "E", "O"}));
  cmd->add_option("--data-bits", t.data_bits, "RTU data bits")->default_val(8)->check(CLI::Range(5, 8));
  cmd->add_option("--stop-bits", t.stop_bits, "RTU stop bits")->default_val(1)->check(CLI::Range(1, 2));
  cmd->add_option("--timeout", t.timeout_ms, "reply timeout in ms")->default_val(1000)->check(CLI::Range(1, 60000));
  cmd->footer(kAddressHelp);
}

[[noreturn]] void fail(int code, const std::string& msg) {
  std::fprintf(stderr, "rtplc modbus: %s\n", msg.c_str());
  throw CLI::RuntimeError(code);
}

// The items of the command line (after HOST for TCP).
std::vector<std::string> items_of(const Target& t, bool need_items) {
  std::vector<std::string> items = t.args;
  if (t.rtu.empty()) {
    if (items.empty()) fail(kExitUsage, "give the slave's HOST (or --rtu DEVICE)");
    // `read --port 1502 hr:0`: the host was forgotten, not the items.
    if (items.front().find(':') != std::string::npos && parse_address(items.front().substr(0, items.front().find('=')))) {
      fail(kExitUsage, "'" + items.front() + "' is an item, not a host: give the slave's HOST first (e.g. " +
                           "127.0.0.1 " + items.front() + "), or --rtu DEVICE");
    }
    items.erase(items.begin());
  }
  if (need_items && items.empty()) fail(kExitUsage, std::string("give at least one item\n") + kAddressHelp);
  return items;
}

Client connect_or_fail(const Target& t) {
  auto c = t.rtu.empty() ? Client::tcp(t.args.front(), t.port)
                         : Client::rtu({t.rtu, t.baud, t.parity[0], static_cast<uint8_t>(t.data_bits),
                                        static_cast<uint8_t>(t.stop_bits)});
  if (!c) fail(kExitFailure, c.error());
  c->set_timeout_ns(int64_t{t.timeout_ms} * 1000000);
  c->set_unit(static_cast<uint8_t>(t.unit));
  const Outcome o = c->connect();
  if (!o.ok()) {
    fail(kExitFailure, fmt::format("cannot connect to {}: {}", t.rtu.empty() ? t.args.front() + ":" + std::to_string(t.port) : t.rtu,
                                   outcome_text(o)));
  }
  return std::move(*c);
}

void run_read(const Target& t) {
  std::vector<Address> items;
  std::string errors;
  for (const std::string& s : items_of(t, true)) {
    auto a = parse_address(s);
    if (a) items.push_back(*a);
    else errors += (errors.empty() ? "" : "\nrtplc modbus: ") + a.error();
  }
  if (!errors.empty()) fail(kExitUsage, errors + "\n" + kAddressHelp);
  Client c = connect_or_fail(t);
  bool failed = false;
  for (const Address& a : items) {
    uint16_t w[2] = {};
    const Outcome o = c.read(a.table, a.address, width(a), w);
    if (o.ok()) {
      std::printf("%s = %s\n", to_string(a).c_str(), format_value(a, decode(a, w)).c_str());
    } else {
      std::fprintf(stderr, "rtplc modbus: %s: %s\n", to_string(a).c_str(), outcome_text(o).c_str());
      failed = true;
      if (o.kind == Outcome::Kind::kLink) break;
    }
  }
  std::fflush(stdout);
  if (failed) throw CLI::RuntimeError(kExitFailure);
}

void run_write(const Target& t) {
  std::vector<Assignment> items;
  std::string errors;
  for (const std::string& s : items_of(t, true)) {
    auto a = parse_assignment(s);
    if (a) items.push_back(*a);
    else errors += (errors.empty() ? "" : "\nrtplc modbus: ") + a.error();
  }
  // Every value is checked before anything is sent.
  if (!errors.empty()) fail(kExitUsage, errors + "\n" + kAddressHelp);
  Client c = connect_or_fail(t);
  bool failed = false;
  for (const Assignment& a : items) {
    uint16_t w[2] = {};
    encode(a.address, a.value, w);
    const Outcome o = c.write(a.address, w);
    if (o.ok()) {
      std::printf("%s = %s\n", to_string(a.address).c_str(), format_value(a.address, a.value).c_str());
    } else {
      std::fprintf(stderr, "rtplc modbus: %s: %s\n", to_string(a.address).c_str(), outcome_text(o).c_str());
      failed = true;
      if (o.kind == Outcome::Kind::kLink) break;
    }
  }
  std::fflush(stdout);
  if (failed) throw CLI::RuntimeError(kExitFailure);
}

void run_scan(const Target& t, int from, int to, const std::string& probe_text) {
  auto probe = parse_address(probe_text);
  if (!probe) fail(kExitUsage, probe.error());
  if (!items_of(t, false).empty()) fail(kExitUsage, "scan takes no items (see --probe)");
  if (from > to) fail(kExitUsage, fmt::format("--from {} is above --to {}: nothing would be scanned", from, to));
  Client c = connect_or_fail(t);
  int found = 0;
  for (int unit = from; unit <= to; ++unit) {
    c.set_unit(static_cast<uint8_t>(unit));
    uint16_t w[2] = {};
    Outcome o = c.read(probe->table, probe->address, width(*probe), w);
    if (o.kind == Outcome::Kind::kLink) {
      c = connect_or_fail(t);  // a slave that hangs up on an unknown unit
      continue;
    }
    if (o.kind == Outcome::Kind::kTimeout || o.kind == Outcome::Kind::kProtocol || o.kind == Outcome::Kind::kBadCrc) {
      c.flush();
      continue;
    }
    ++found;
    if (o.ok()) std::printf("unit %d answers (%s = %s)\n", unit, to_string(*probe).c_str(), format_value(*probe, decode(*probe, w)).c_str());
    else std::printf("unit %d answers (%s)\n", unit, outcome_text(o).c_str());
    std::fflush(stdout);
  }
  std::printf("%d unit(s) answered of %d..%d\n", found, from, to);
}

std::atomic<bool> g_stop{false};

void run_fake_slave(FakeSlaveOptions opt, const std::vector<std::string>& sets) {
  FakeSlave slave(opt);
  for (const std::string& s : sets) {
    auto a = parse_address(s.substr(0, s.find('=')));
    if (!a) fail(kExitUsage, a.error());
    char* end = nullptr;
    const std::string v = s.find('=') == std::string::npos ? "" : s.substr(s.find('=') + 1);
    const double value = std::strtod(v.c_str(), &end);
    if (s.find('=') == std::string::npos) fail(kExitUsage, fmt::format("--set '{}': expected ADDRESS=VALUE, e.g. hr:4:f32=21.5", s));
    if (v.empty() || *end != '\0') fail(kExitUsage, fmt::format("--set '{}': '{}' is not a number", s, v));
    if (auto r = check_value(*a, value); !r) fail(kExitUsage, fmt::format("--set '{}': {}", s, r.error()));
    slave.put(*a, value);
  }
  if (auto r = slave.start(); !r) fail(kExitFailure, r.error());
  const std::string where = slave.rtu() ? fmt::format("RTU slave on {} ({} baud {}{}{})", opt.serial.device, opt.serial.baud,
                                                      int{opt.serial.data_bits}, opt.serial.parity, int{opt.serial.stop_bits})
                                        : fmt::format("TCP slave on {}:{}", opt.bind, slave.port());
  std::printf("fake Modbus %s (magic addresses: 65281..65291 exception 1..11, %u delay, %u drop, "
              "%u bad length, %u silent, %u wrong %s id, %u bad CRC%s); Ctrl-C stops\n",
              where.c_str(), kMagicDelay, kMagicDrop, kMagicBadLength, kMagicSilent, kMagicBadId,
              slave.rtu() ? "unit" : "transaction", kMagicBadCrc, slave.rtu() ? "" : " (RTU only)");
  std::fflush(stdout);
  signal(SIGINT, [](int) { g_stop.store(true); });
  signal(SIGTERM, [](int) { g_stop.store(true); });
  while (!g_stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  slave.stop();
}

}  // namespace

void add_commands(CLI::App& app) {
  CLI::App* mb = app.add_subcommand("modbus", "Modbus commissioning: read, write, scan, fake-slave");
  mb->require_subcommand(1);

  auto* read = mb->add_subcommand("read", "read items from a slave and print ADDR = VALUE per line");
  static Target rt;
  add_target_options(read, rt, "HOST (TCP) then items: hr:0 hr:4:f32 coil:5 di:3 ir:7:i16");
  read->callback([] { run_read(rt); });

  auto* write = mb->add_subcommand("write", "write items to a slave (every value checked before anything is sent)");
  static Target wt;
  add_target_options(write, wt, "HOST (TCP) then ADDRESS=VALUE: hr:20=513 coil:21=1 hr:22:f32=1.5");
  write->callback([] { run_write(wt); });

  auto* scan = mb->add_subcommand("scan", "which unit ids answer on a line (or behind a TCP gateway)");
  static Target st;
  static int from = 1, to = 247;
  static std::string probe = "hr:0";
  add_target_options(scan, st, "HOST (TCP)");
  scan->add_option("--from", from, "first unit id")->default_val(1)->check(CLI::Range(0, 247));
  scan->add_option("--to", to, "last unit id")->default_val(247)->check(CLI::Range(0, 247));
  scan->add_option("--probe", probe, "the item read from each unit (an exception counts as an answer)")->default_val("hr:0");
  scan->callback([] {
    if (st.timeout_ms == 1000) st.timeout_ms = 100;  // a scan waits on many silent units
    run_scan(st, from, to, probe);
  });

  auto* fake = mb->add_subcommand("fake-slave",
                                  "serve a fault-injecting Modbus slave over TCP, or RTU on a serial device or pty "
                                  "(for trying without hardware)");
  static FakeSlaveOptions fo;
  static std::vector<std::string> sets;
  static std::vector<int> units;
  static int delay_ms = 2000;
  static std::string fparity = "E";
  static int fdata = 8, fstop = 1;
  fake->add_option("--port", fo.port, "TCP port")->default_val(1502);
  fake->add_option("--bind", fo.bind, "IPv4 address to listen on")->default_val("127.0.0.1");
  fake->add_option("--rtu", fo.serial.device,
                   "serve Modbus RTU on this serial device instead of TCP (a pty: the end of a socat pair)");
  fake->add_option("--baud", fo.serial.baud, "RTU bits per second")->default_val(19200);
  fake->add_option("--parity", fparity, "RTU parity: N, E or O (on a pty use N: pymodbus cannot set E there)")
      ->default_val("E")
      ->check(CLI::IsMember({"N", "E", "O"}));
  fake->add_option("--data-bits", fdata, "RTU data bits")->default_val(8)->check(CLI::Range(5, 8));
  fake->add_option("--stop-bits", fstop, "RTU stop bits")->default_val(1)->check(CLI::Range(1, 2));
  fake->add_option("--unit", units, "units that answer (repeatable; default every unit)")->check(CLI::Range(0, 247));
  fake->add_option("--set", sets, "initial value ADDRESS=VALUE (repeatable): --set hr:4:f32=21.5");
  fake->add_option("--delay", delay_ms, "ms the magic delay address waits")->default_val(2000);
  fake->footer(
      "Magic addresses (a request whose range covers one misbehaves, every time):\n"
      "  65281..65291  exception 1..11 (address - 65280)   65500  answers after --delay ms\n"
      "  65501  drops the connection (RTU: silence)          65502  read answer with a wrong byte count\n"
      "  65503  never answers                                65504  wrong transaction id (RTU: unit id)\n"
      "  65505  RTU: answer with a bad CRC (TCP answers normally)\n"
      "RTU without hardware, over a pty pair (parity N: a pty has no UART, and pyserial cannot set E on one):\n"
      "  socat -d -d pty,raw,echo=0,link=/tmp/ptyA pty,raw,echo=0,link=/tmp/ptyB &\n"
      "  rtplc modbus fake-slave --rtu /tmp/ptyA --parity N --unit 7 &\n"
      "  rtplc modbus read --rtu /tmp/ptyB --parity N --unit 7 hr:0\n");
  fake->callback([fake] {
    if (fo.serial.device.empty()) {
      for (const char* o : {"--baud", "--parity", "--data-bits", "--stop-bits"}) {
        if (fake->count(o) > 0) fail(kExitUsage, fmt::format("{} applies to RTU only (give --rtu DEVICE)", o));
      }
    } else {
      for (const char* o : {"--port", "--bind"}) {
        if (fake->count(o) > 0) fail(kExitUsage, fmt::format("{} applies to TCP only, not with --rtu", o));
      }
    }
    for (int u : units) fo.units.push_back(static_cast<uint8_t>(u));
    fo.serial.parity = fparity[0];
    fo.serial.data_bits = static_cast<uint8_t>(fdata);
    fo.serial.stop_bits = static_cast<uint8_t>(fstop);
    fo.delay_ns = int64_t{delay_ms} * 1000000;
    run_fake_slave(fo, sets);
  });
}

}  // namespace rtplc::modbus
