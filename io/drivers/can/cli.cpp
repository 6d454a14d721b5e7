// `rtplc can ...`: commissioning commands for the CAN link (issue "CAN/GPIO",
// item 3). `dump` prints the frames on an interface, decoded by a config's
// can driver mapping when one is given (so the drive's values can be checked
// before any task runs), and the controller's error frames in words.
#include <signal.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <cstdio>
#include <string>
#include <unistd.h>
#include <vector>

#include "io/drivers/can/cli.h"

#include "common/exit_codes.h"
#include "config/config.h"
#include "io/drivers/can/config.h"
#include "io/drivers/can/transport.h"

namespace rtplc::can {
namespace {

std::atomic<bool> g_interrupted{false};

void on_signal(int) {
  g_interrupted.store(true);
}

[[noreturn]] void fail(int code, const std::string& msg) {
  std::fprintf(stderr, "rtplc can: %s\n", msg.c_str());
  throw CLI::RuntimeError(code);
}

struct DumpArgs {
  std::string iface;
  std::string config;
  std::string driver;
  uint64_t count = 0;
  double seconds = 0;
};

// The can driver of `file` (the one named `driver`, or the only one).
CanSettings mapping_of(const DumpArgs& a) {
  config::LoadResult cfg = config::load_config(a.config, {.check_program_files = false});
  if (!cfg.diags.items().empty()) std::fputs(cfg.render(isatty(STDERR_FILENO) != 0).c_str(), stderr);
  if (!cfg.ok()) fail(kExitFailure, a.config + ": the configuration has errors");
  std::vector<const config::DriverConfig*> cans;
  for (const config::DriverConfig& d : cfg.config->drivers) {
    if (d.kind == "can" && (a.driver.empty() || d.name == a.driver)) cans.push_back(&d);
  }
  if (cans.empty()) {
    fail(kExitUsage, a.driver.empty() ? a.config + " has no driver of kind can"
                                      : a.config + " has no can driver named '" + a.driver + "'");
  }
  if (cans.size() > 1) fail(kExitUsage, a.config + " has several can drivers: say which with --driver NAME");
  return settings_of(*cans.front());
}

std::string decoded(const CanSettings& s, const Frame& f) {
  std::string out;
  for (const auto* frames : {&s.receive, &s.transmit}) {
    for (const FrameMap& fm : *frames) {
      if (fm.id != f.id || fm.extended != f.extended) continue;
      const char* dir = frames == &s.receive ? "in" : "out";
      if (f.len < fm.length) {
        out += fmt::format("  ({} frame: {} bytes, the mapping needs {})", dir, f.len, fm.length);
        continue;
      }
      for (const SignalMap& m : fm.signals) out += fmt::format("  {}/EPC/{}={:g}", dir, m.channel, unpack(m.layout, f.data));
    }
  }
  return out;
}

void dump(const DumpArgs& a) {
  CanSettings mapping;
  if (!a.config.empty()) mapping = mapping_of(a);
  if (auto r = socketcan_available(); !r) fail(kExitFailure, r.error());
  // Everything on the bus: standard and extended ids, and error frames.
  const IdFilter all[] = {{0, false, 0}, {0, true, 0}};
  auto port = Port::open(socketcan_transport(), a.iface, all, true);
  if (!port) fail(kExitFailure, port.error());
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  uint64_t seen = 0;
  const auto start = std::chrono::steady_clock::now();
  while (!g_interrupted.load() && (a.count == 0 || seen < a.count)) {
    if (a.seconds > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= a.seconds) {
      break;
    }
    Frame f;
    int err = 0;
    const RecvResult r = port->recv(f, 100000000, &err);
    if (r == RecvResult::kTimeout) continue;
    if (r == RecvResult::kError) fail(kExitFailure, fmt::format("{}: receiving failed: {}", a.iface, std::strerror(err)));
    ++seen;
    if (f.error) {
      std::printf("%s  error frame: %s\n", a.iface.c_str(), error_text(decode_error(f)).c_str());
    } else {
      std::string bytes;
      for (unsigned i = 0; i < f.len; ++i) bytes += fmt::format(" {:02X}", f.data[i]);
      std::printf("%s  %s  [%u]%s%s\n", a.iface.c_str(), id_text(f.id, f.extended).c_str(), f.len, bytes.c_str(),
                  decoded(mapping, f).c_str());
    }
    std::fflush(stdout);
  }
}

}  // namespace

void add_commands(CLI::App& app) {
  CLI::App* can = app.add_subcommand("can", "Commissioning of the CAN link to the drives (`kind: can`)");
  can->require_subcommand(1);
  static DumpArgs args;
  args = DumpArgs{};  // one set per app built (tests build several)
  DumpArgs* a = &args;
  CLI::App* d = can->add_subcommand(
      "dump", "Print the frames on a CAN interface, decoded by a config's can driver mapping");
  d->add_option("IFACE", a->iface, "the SocketCAN interface: can0, vcan0")->required();
  d->add_option("--config", a->config, "decode the ids this config's can driver maps (receive as in/, transmit as out/)");
  d->add_option("--driver", a->driver, "the can driver of --config to use when it has several");
  d->add_option("-n,--count", a->count, "stop after this many frames (default: until Ctrl-C)");
  d->add_option("--seconds", a->seconds, "stop after this long")->check(CLI::PositiveNumber);
  d->footer(
      "Each line: interface, id (3 hex digits, or 8 and 'x' for a 29-bit id), [length], the data\n"
      "bytes, then for a mapped id every signal as CHANNEL=VALUE (scaled). Error frames are\n"
      "printed in words (bus-off, restarted, error-passive, no-ack...).\n"
      "Example:\n  rtplc can dump vcan0 --config examples/drive.yaml -n 10\n");
  d->callback([a] { dump(*a); });
}

}  // namespace rtplc::can
