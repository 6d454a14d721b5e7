// The `gpio` driver kind of the configuration (issue "CAN/GPIO", GPIO half):
// the default chip, and the input, output and counter lines with their
// channels. Everything that can be checked without the hardware is checked
// here with a position; a line name is looked up on its chip at start, and a
// name or offset the chip does not have fails the start naming the entry's
// line:column.
#include <fmt/format.h>

#include <map>
#include <string>

#include "io/drivers/gpio/config.h"

#include "blocks/image.h"
#include "config/map_entries.h"
#include "config/yaml_reader.h"

namespace rtplc::gpio {
using namespace config;
namespace {

const KeySpec kGpioKeys[] = {
    {"chip", ValueType::kText, false, 0, 0, "chip", "none: every entry names its chip",
     "The default chip of the entries: gpiochip0, /dev/gpiochip0, its number or its label "
     "(`rtplc gpio info` lists them)."},
    {"inputs", ValueType::kList, false, 0, 1024, "gpio-line", "no inputs",
     "Lines read into `ddi` channels (`in/DIO/pN.dN.cN`) every driver cycle."},
    {"outputs", ValueType::kList, false, 0, 1024, "gpio-line", "no outputs",
     "Lines driven from `ddo` outputs (`out/DIO/pN.dN.cN`) every driver cycle."},
    {"counters", ValueType::kList, false, 0, 256, "gpio-line", "no counters",
     "Input lines whose edges are counted into `dpi` channels (`in/DIOP/pN.dN.cN`): the "
     "pulses since start, from the kernel's queued edge events, so none is lost between cycles."},
};

const KeySpec kLineKeys[] = {
    {"channel", ValueType::kChannel, true, 0, 0, nullptr, "",
     "The block's address pN.dN.cN (ddi for inputs, ddo for outputs, dpi for counters)."},
    {"line", ValueType::kText, true, 0, 0, "offset or name", "",
     "The line: its offset on the chip (0, 17) or its name (looked up on the chip at start)."},
    {"chip", ValueType::kText, false, 0, 0, "chip", "the driver's `chip`", "This line's chip."},
    {"active_low", ValueType::kBool, false, 0, 0, nullptr, "false",
     "The line is active when low: an input reads 1 at a low level, an output at 1 drives it low."},
    {"bias", ValueType::kChoice, false, 0, 0, "as-is|disable|pull-up|pull-down", "as-is",
     "The line's internal resistor (inputs and counters), if the chip has one."},
    {"debounce", ValueType::kDuration, false, 0, 1, nullptr, "0 (none)",
     "Inputs: a new level counts once it held this long. Counters: an edge closer than this "
     "to the last counted one (by kernel timestamp) is not counted."},
    {"edge", ValueType::kChoice, false, 0, 0, "rising|falling|both", "rising",
     "Counters only: which edges are pulses."},
    {"safe", ValueType::kInteger, false, 0, 1, nullptr, "0",
     "Outputs only: the level driven while the task's value cannot be vouched for (bad quality)."},
};

const SectionSpec kGpioSection{
    "gpio", "a gpio driver", "`kind: gpio`",
    "Direct I/O on GPIO lines of the kernel's character device (libgpiod): the DIO group. "
    "Every `period` the driver reads its input lines and drives its output lines from the "
    "tasks' outputs; an I/O thread (below the task band) counts the counter lines' edge "
    "events and debounces inputs. After `rtplc stop` (and when the watchdog stops a task) the "
    "outputs are driven to the tasks' safe values. The lines are one link row per chip in "
    "`rtplc status`/`stats`.",
    kGpioKeys};
const SectionSpec kLineSection{"gpio-line", "a GPIO line",
                               "`inputs:`, `outputs:` and `counters:` entries of a gpio driver", "", kLineKeys};
const SectionSpec* const kSubsections[] = {&kLineSection};

bool valid_chip(YamlReader& r, const Field& f, std::string& out) {
  auto v = r.text(f);
  if (!v) return false;
  if (v->find_first_of(" \t") != std::string::npos) {
    r.error(f, "'chip' expects a chip (gpiochip0, /dev/gpiochip0, 0 or a label), got '" + *v + "'");
    return false;
  }
  out = *v;
  return true;
}

void parse_line(YamlReader& r, const YAML::Node& node, SourcePos where, Role role, const std::string& chip,
                std::vector<LineMap>& out) {
  LineMap m;
  m.role = role;
  m.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  m.line_pos = m.pos;
  m.chip = chip;
  m.edge = role == Role::kCounter ? Edge::kRising : Edge::kNone;
  Fields f = r.fields(node, m.pos, kLineSection.noun, {kLineSection.keys});
  if (!f.is_map()) return;
  bool ok = parse_channel_field(r, f, "channel", false, m.addr, m.channel);
  if (const Field* l = f.get("line")) {
    m.line_pos = l->pos;
    if (auto t = r.text(*l)) {
      const bool digits = t->find_first_not_of("0123456789") == std::string::npos;
      if (digits && t->size() <= 6) {
        m.offset = static_cast<unsigned>(std::stoul(*t));
      } else if (digits || (*t)[0] == '-') {
        r.error(*l, "'line' expects an offset (0..65535) or a line name, got '" + *t + "'");
        ok = false;
      } else {
        m.line_name = *t;
      }
    } else {
      ok = false;
    }
  }
  if (const Field* c = f.get("chip")) ok = valid_chip(r, *c, m.chip) && ok;
  if (m.chip.empty() && f.get("line")) {
    r.error(*f.get("line"), "which chip? give the driver a 'chip' or this entry one (`rtplc gpio info` lists them)");
    ok = false;
  }
  if (const Field* a = f.get("active_low")) {
    if (auto v = r.boolean(*a)) m.active_low = *v;
    else ok = false;
  }
  if (const Field* b = f.get("bias")) {
    if (role == Role::kOutput) {
      r.error(*b, "'bias' applies to inputs and counters only");
      ok = false;
    } else if (auto v = r.choice(*b)) {
      m.bias = *v == "disable" ? Bias::kDisable : *v == "pull-up" ? Bias::kPullUp
               : *v == "pull-down"                                ? Bias::kPullDown
                                                                  : Bias::kAsIs;
    } else {
      ok = false;
    }
  }
  if (const Field* d = f.get("debounce")) {
    if (role == Role::kOutput) {
      r.error(*d, "'debounce' applies to inputs and counters only");
      ok = false;
    } else if (auto v = r.duration(*d)) {
      m.debounce_ns = static_cast<int64_t>(*v * 1e9 + 0.5);
    } else {
      ok = false;
    }
  }
  if (const Field* e = f.get("edge")) {
    if (role != Role::kCounter) {
      r.error(*e, "'edge' applies to counters only (an input is read as a level)");
      ok = false;
    } else if (auto v = r.choice(*e)) {
      m.edge = *v == "falling" ? Edge::kFalling : *v == "both" ? Edge::kBoth : Edge::kRising;
    } else {
      ok = false;
    }
  }
  if (const Field* s = f.get("safe")) {
    if (role != Role::kOutput) {
      r.error(*s, "'safe' applies to outputs only");
      ok = false;
    } else if (auto v = r.integer(*s)) {
      m.safe = static_cast<int>(*v);
    } else {
      ok = false;
    }
  }
  if (ok) out.push_back(std::move(m));
}

void parse_gpio(YamlReader& r, const Fields& f, DriverConfig& out) {
  GpioSettings s;
  if (const Field* c = f.get("chip")) (void)valid_chip(r, *c, s.chip);
  const std::pair<const char*, Role> lists[] = {
      {"inputs", Role::kInput}, {"counters", Role::kCounter}, {"outputs", Role::kOutput}};
  for (const auto& [key, role] : lists) {
    const Field* list = f.get(key);
    if (!list) continue;
    auto items = r.list(*list);
    if (!items) continue;
    for (const YAML::Node& n : *items) parse_line(r, n, list->pos, role, s.chip, s.lines);
  }
  // One line, one use: a line is requested once (an input cannot also be counted;
  // a dpi counts it and a ddi of another line reads the level).
  FirstSeen seen;
  FirstSeen channels;
  size_t with_events = 0;
  for (const LineMap& m : s.lines) {
    if ((m.role == Role::kCounter || (m.role == Role::kInput && m.debounce_ns > 0)) &&
        ++with_events == kMaxEventLines + 1) {
      r.error(m.line_pos, fmt::format("a gpio driver follows the edges of at most {} lines (counters and "
                                      "debounced inputs); this is one more: use a second gpio driver",
                                      kMaxEventLines));
    }
    const std::string key = m.chip + "/" + (m.line_name.empty() ? std::to_string(m.offset) : "'" + m.line_name + "'");
    if (auto first = seen.again(key, m.line_pos)) {
      r.error(m.line_pos,
              fmt::format("{} of chip {} is already used by the entry at line {}", line_text(m), m.chip, *first));
    }
    if (m.role != Role::kOutput) continue;  // (an input provided twice is the loader's error)
    if (auto first = channels.again(m.channel, m.pos)) {
      r.error(m.pos, fmt::format("output {} drives two lines (first at line {})", m.channel, *first));
    }
  }
  if (s.lines.empty() && !f.get("inputs") && !f.get("outputs") && !f.get("counters")) {
    r.error(f.get("chip") ? f.get("chip")->pos : SourcePos{},
            "a gpio driver needs 'inputs', 'outputs' or 'counters' (it maps no lines)");
  }
  out.settings = std::move(s);
}

std::string gpio_doc() {
  return "Example: a start button, a pulse meter and a lamp on gpiochip0:\n\n```yaml\ndrivers:\n"
         "  - kind: gpio\n    name: dio\n    period: 1ms\n    chip: gpiochip0\n    inputs:\n"
         "      - {channel: p0.d0.c0, line: START_BTN, active_low: true, bias: pull-up, debounce: 5ms}\n"
         "    counters:\n      - {channel: p0.d0.c1, line: 5, edge: rising}\n"
         "    outputs:\n      - {channel: p0.d0.c0, line: 6, safe: 0}\n```\n\n"
         "See docs/gpio.md for the link rows, `rtplc gpio` and the tests.\n";
}

ChannelClaim claim(const DriverConfig& d, const LineMap& m) {
  const BindingDir dir = m.role == Role::kOutput ? BindingDir::kOutput : BindingDir::kInput;
  const char device = m.role == Role::kCounter ? 'P' : 0;
  return {channel_key(dir, IoGroup::kDio, device, m.addr.p, m.addr.d, m.addr.c),
          fmt::format("{}.{}", d.name, m.channel), m.pos};
}

// Inputs and counters provide channels (region order: inputs, counters, as
// listed), outputs consume task outputs; one link row per chip.
DriverClaims gpio_claims(const DriverConfig& d) {
  const GpioSettings& s = settings_of(d);
  DriverClaims c;
  std::map<std::string, int> chips;
  for (const LineMap& m : s.lines) {
    (m.role == Role::kOutput ? c.consumes : c.provides).push_back(claim(d, m));
    chips[m.chip] = 1;
  }
  c.links = static_cast<uint32_t>(chips.size());
  return c;
}

}  // namespace

std::string line_text(const LineMap& m) { return line_chars(m).s; }

LineChars line_chars(const LineMap& m) noexcept {
  LineChars t{};
  const auto r = m.line_name.empty() ? fmt::format_to_n(t.s, sizeof t.s - 1, "line {}", m.offset)
                                     : fmt::format_to_n(t.s, sizeof t.s - 1, "line '{}'", m.line_name);
  *r.out = '\0';
  return t;
}

const GpioSettings& settings_of(const DriverConfig& d) { return settings_as<GpioSettings>(d); }

const DriverKind kConfigKind{
    "gpio",        "GPIO lines (libgpiod) as direct I/O: ddi, ddo and dpi pulse counters",
    &kGpioSection, kSubsections,
    &parse_gpio,   &gpio_claims,
    &gpio_doc,
};

}  // namespace rtplc::gpio
