// `rtplc gpio ...`: commissioning commands for GPIO lines (issue "CAN/GPIO",
// GPIO half), to check the wiring from the box before any task runs:
//   info [CHIP] [--config FILE]  the chips and their lines (name, user,
//                                direction); with --config, every line of the
//                                file's gpio drivers checked against the chips,
//                                a bad one reported at its file:line:col;
//   get CHIP LINE...             read input levels;
//   set CHIP LINE=V...           drive outputs (held for --hold).
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "io/drivers/gpio/cli.h"

#include "common/exit_codes.h"
#include "config/config.h"
#include "io/drivers/gpio/chip.h"
#include "io/drivers/gpio/config.h"

namespace rtplc::gpio {
namespace {

std::atomic<bool> g_interrupted{false};

void on_signal(int) {
  g_interrupted.store(true);
}

[[noreturn]] void fail(int code, const std::string& msg) {
  std::fprintf(stderr, "rtplc gpio: %s\n", msg.c_str());
  throw CLI::RuntimeError(code);
}

struct Args {
  const ChipOps* ops = nullptr;
  std::string chip;
  std::string config;
  std::vector<std::string> lines;
  bool active_low = false;
  std::string bias = "as-is";
  double hold = 0;
};

struct OpenChip {
  const ChipOps* ops;
  void* chip;
  ~OpenChip() { ops->close(chip); }
};

OpenChip open(const Args& a, const std::string& chip) {
  auto c = a.ops->open(a.ops->context, chip);
  if (!c) fail(kExitFailure, c.error());
  return {a.ops, *c};
}

unsigned offset_of(const OpenChip& c, const std::string& line) {
  const ChipInfo ci = c.ops->chip_info(c.chip);
  if (!line.empty() && line.find_first_not_of("0123456789") == std::string::npos && line.size() <= 6) {
    const auto off = static_cast<unsigned>(std::stoul(line));
    if (off >= ci.lines) fail(kExitUsage, fmt::format("{} has {} lines (0..{}), not line {}", ci.name, ci.lines, ci.lines - 1, off));
    return off;
  }
  const int off = c.ops->find(c.chip, line);
  if (off < 0) fail(kExitUsage, fmt::format("{} has no line named '{}' (`rtplc gpio info {}` lists its lines)", ci.name, line, ci.name));
  return static_cast<unsigned>(off);
}

void print_chip(const OpenChip& c) {
  const ChipInfo ci = c.ops->chip_info(c.chip);
  std::printf("%s  [%s]  %u lines\n", ci.name.c_str(), ci.label.c_str(), ci.lines);
  for (unsigned i = 0; i < ci.lines; ++i) {
    const LineInfo li = c.ops->line_info(c.chip, i);
    std::printf("  line %3u  %-16s  %-6s  %s%s\n", i, li.name.empty() ? "-" : li.name.c_str(),
                li.output ? "output" : "input", li.used ? ("used by " + (li.consumer.empty() ? std::string("kernel") : li.consumer)).c_str() : "free",
                li.active_low ? "  active-low" : "");
  }
}

// Every line of the config's gpio drivers against the chips; returns the errors found.
int check_config(const Args& a) {
  config::LoadResult cfg = config::load_config(a.config, {.check_program_files = false});
  if (!cfg.diags.items().empty()) std::fputs(cfg.render(isatty(STDERR_FILENO) != 0).c_str(), stderr);
  if (!cfg.ok()) fail(kExitFailure, a.config + ": the configuration has errors");
  int errors = 0;
  int seen = 0;
  for (const config::DriverConfig& d : cfg.config->drivers) {
    if (d.kind != "gpio") continue;
    ++seen;
    for (const LineMap& m : settings_of(d).lines) {
      auto here = [&](const std::string& why) {
        std::fprintf(stderr, "%s:%u:%u: error: %s\n", a.config.c_str(), m.line_pos.line, m.line_pos.col, why.c_str());
        ++errors;
      };
      auto c = a.ops->open(a.ops->context, m.chip);
      if (!c) {
        here(c.error());
        continue;
      }
      const ChipInfo ci = a.ops->chip_info(*c);
      int off = static_cast<int>(m.offset);
      if (!m.line_name.empty()) off = a.ops->find(*c, m.line_name);
      if (off < 0) {
        here(fmt::format("chip {} has no line named '{}'", ci.name, m.line_name));
      } else if (static_cast<unsigned>(off) >= ci.lines) {
        here(fmt::format("chip {} has {} lines (0..{}), not line {}", ci.name, ci.lines, ci.lines - 1, off));
      } else {
        const LineInfo li = a.ops->line_info(*c, static_cast<unsigned>(off));
        std::printf("%s.%s  %s %s = %s line %d%s\n", d.name.c_str(), m.channel.c_str(),
                    m.role == Role::kOutput ? "output" : m.role == Role::kCounter ? "counter" : "input",
                    line_text(m).c_str(), ci.name.c_str(), off,
                    li.used ? (" (now used by " + li.consumer + ")").c_str() : "");
      }
      a.ops->close(*c);
    }
  }
  if (seen == 0) fail(kExitUsage, a.config + " has no driver of kind gpio");
  return errors;
}

void info(const Args& a) {
  if (!a.config.empty()) {
    const int errors = check_config(a);
    if (errors > 0) fail(kExitFailure, fmt::format("{} line(s) of {} do not match the chips", errors, a.config));
    return;
  }
  if (!a.chip.empty()) {
    print_chip(open(a, a.chip));
    return;
  }
  if (a.ops == &gpiod_chip_ops()) {
    if (auto r = gpio_cdev_available(); !r) fail(kExitFailure, r.error());
  }
  int shown = 0;
  for (int n = 0; n < 64; ++n) {
    auto c = a.ops->open(a.ops->context, fmt::format("gpiochip{}", n));
    if (!c) continue;
    print_chip(OpenChip{a.ops, *c});
    ++shown;
  }
  if (shown == 0) fail(kExitFailure, "no GPIO chip could be opened (permissions of /dev/gpiochipN?)");
}

LineRequest request_for(const Args& a, unsigned offset, bool output, int value) {
  LineRequest r;
  r.offset = offset;
  r.output = output;
  r.active_low = a.active_low;
  r.bias = a.bias == "pull-up" ? Bias::kPullUp : a.bias == "pull-down" ? Bias::kPullDown
           : a.bias == "disable" ? Bias::kDisable : Bias::kAsIs;
  r.initial = value;
  return r;
}

void get(const Args& a) {
  OpenChip c = open(a, a.chip);
  for (const std::string& line : a.lines) {
    const unsigned off = offset_of(c, line);
    auto l = a.ops->request(c.chip, request_for(a, off, false, 0), "rtplc-gpio-get");
    if (!l) fail(kExitFailure, l.error());
    const int v = a.ops->get(*l);
    a.ops->release(*l);
    if (v < 0) fail(kExitFailure, fmt::format("reading line {} failed: {}", off, std::strerror(-v)));
    std::printf("%s line %u = %d\n", a.chip.c_str(), off, v);
  }
}

void set(const Args& a) {
  OpenChip c = open(a, a.chip);
  std::vector<void*> held;
  for (const std::string& item : a.lines) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos || (item.substr(eq + 1) != "0" && item.substr(eq + 1) != "1")) {
      fail(kExitUsage, fmt::format("'{}': say LINE=0 or LINE=1", item));
    }
    const unsigned off = offset_of(c, item.substr(0, eq));
    const int v = item[eq + 1] - '0';
    auto l = a.ops->request(c.chip, request_for(a, off, true, v), "rtplc-gpio-set");
    if (!l) fail(kExitFailure, l.error());
    held.push_back(*l);
    std::printf("%s line %u := %d\n", a.chip.c_str(), off, v);
  }
  std::fflush(stdout);
  if (a.hold != 0) {
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.hold);
    while (!g_interrupted.load() && (a.hold < 0 || std::chrono::steady_clock::now() < end)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  for (void* l : held) a.ops->release(l);
}

}  // namespace

void add_commands(CLI::App& app) {
  add_commands_with(app, gpiod_chip_ops());
}

void add_commands_with(CLI::App& app, const ChipOps& ops) {
  CLI::App* g = app.add_subcommand("gpio", "Commissioning of GPIO lines (`kind: gpio`): list, read, drive");
  g->require_subcommand(1);
  static Args args;
  args = Args{};  // one set per app built (tests build several)
  args.ops = &ops;
  Args* a = &args;
  CLI::App* i = g->add_subcommand("info", "List the GPIO chips and their lines, or check a config's lines against them");
  i->add_option("CHIP", a->chip, "one chip: gpiochip0, /dev/gpiochip0, 0 or its label");
  i->add_option("--config", a->config, "check every line of this config's gpio drivers (errors at file:line:col)");
  i->footer("Each line: offset, name, direction, who uses it. Example:\n"
            "  rtplc gpio info gpiochip0\n  rtplc gpio info --config examples/drive.yaml\n");
  i->callback([a] { info(*a); });

  auto common = [a](CLI::App* s) {
    s->add_flag("--active-low", a->active_low, "the line is active when low");
    s->add_option("--bias", a->bias, "as-is, disable, pull-up or pull-down")
        ->check(CLI::IsMember({"as-is", "disable", "pull-up", "pull-down"}));
  };
  CLI::App* gt = g->add_subcommand("get", "Read input lines (requested as inputs for the moment of the read)");
  gt->add_option("CHIP", a->chip, "the chip")->required();
  gt->add_option("LINE", a->lines, "offsets or line names")->required();
  common(gt);
  gt->footer("Example:\n  rtplc gpio get gpiochip0 3 START_BTN --bias pull-up\n");
  gt->callback([a] { get(*a); });

  CLI::App* st = g->add_subcommand("set", "Drive output lines");
  st->add_option("CHIP", a->chip, "the chip")->required();
  st->add_option("LINE=V", a->lines, "offset or line name = 0 or 1")->required();
  common(st);
  st->add_option("--hold", a->hold, "keep driving for this many seconds (-1: until Ctrl-C); a released line may "
                                     "fall back to its default level");
  st->footer("A line in use by a running rtplc is refused (busy). Example:\n"
             "  rtplc gpio set gpiochip0 6=1 LAMP=0 --hold 5\n");
  st->callback([a] { set(*a); });
}

}  // namespace rtplc::gpio
