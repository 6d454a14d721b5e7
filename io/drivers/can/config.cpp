// The `can` driver kind of the configuration (issue "CAN/GPIO", items 1 and 4):
// the interface, and the receive and transmit frames with the signals that map
// their bytes to EPC channels; and the fieldbus plan the link may run on (issue
// 11, item 4: `plan`, `bulk`, a frame's `loop` or `class`), planned here. Every id, byte range and encoding is checked
// here with a position, so a config that loads never fails later (except an
// interface that is missing when the driver starts).
#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <algorithm>
#include <map>
#include <string>

#include "io/drivers/can/config.h"

#include "blocks/image.h"
#include "config/map_entries.h"
#include "config/yaml_reader.h"

namespace rtplc::can {
using namespace config;
namespace {

const KeySpec kCanKeys[] = {
    {"interface", ValueType::kText, true, 0, 0, "interface name", "",
     "The SocketCAN interface: can0, vcan0. One that does not exist fails the start."},
    {"error_frames", ValueType::kBool, false, 0, 0, nullptr, "true",
     "Receive the controller's error frames: bus-off, restart and error states are counted "
     "and logged."},
    {"receive", ValueType::kList, false, 0, 2048, "can-frame", "no receive frames",
     "Frames read into `tra`/`trd` channels (`in/EPC/pN.dN.cN`); the socket wakes only for "
     "these ids."},
    {"transmit", ValueType::kList, false, 0, 2048, "can-frame", "no transmit frames",
     "Frames built from `twa`/`twd` outputs (`out/EPC/pN.dN.cN`)."},
    {"plan", ValueType::kPath, false, 0, 0, nullptr, "unplanned",
     "The fieldbus plan the link runs on: an `rtplc fieldbus plan` input file (relative to this "
     "file) with `bit_rate` and a `can-11`/`can-29` layout. It is planned when the config loads; "
     "a design that cannot work refuses to start with the planner's reason. Every transmit frame "
     "then needs `loop` or `class: urgent`, and the driver `period` must divide T_1 "
     "(docs/fieldbus.md, \"Running a link on a plan\")."},
    {"bulk", ValueType::kList, false, 0, 16, "can-bulk", "no non-RT transfers",
     "With a `plan`: non-RT transfers, sent in what the plan leaves of each T_1 frame in "
     "fragments of at most L_n."},
};

const KeySpec kBulkKeys[] = {
    {"id", ValueType::kText, true, 0, 0, "0x5F0 or 1520", "", "The CAN identifier the transfer's frames carry."},
    {"extended", ValueType::kBool, false, 0, 0, nullptr, "id > 0x7FF", "A 29-bit identifier."},
    {"file", ValueType::kPath, true, 0, 0, nullptr, "",
     "The bytes to send (relative to this file), 8 to a frame in order; read at start."},
    {"every", ValueType::kDuration, false, 0.001, 86400, nullptr, "once, at start",
     "Send the file again this long after the previous transfer began (when it has ended)."},
};

const KeySpec kFrameKeys[] = {
    {"id", ValueType::kText, true, 0, 0, "0x181 or 385", "",
     "The CAN identifier, hexadecimal with 0x or decimal: 11 bits (up to 0x7FF) unless "
     "`extended`."},
    {"extended", ValueType::kBool, false, 0, 0, nullptr, "id > 0x7FF",
     "A 29-bit identifier (up to 0x1FFFFFFF)."},
    {"length", ValueType::kInteger, false, 0, 8, nullptr, "8 (transmit), the signals' end (receive)",
     "Transmit: the frame's data length. Receive: a shorter frame is refused (counted as an "
     "error, channels keep their state)."},
    {"period", ValueType::kDuration, false, 0.001, 3600, nullptr, "100ms",
     "Transmit only: the frame is sent this often."},
    {"on_change", ValueType::kBool, false, 0, 0, nullptr, "true",
     "Transmit only: also send the frame at the next driver cycle after one of its values "
     "changed."},
    {"timeout", ValueType::kDuration, false, 0.001, 3600, nullptr, "500ms",
     "Receive only: no frame for this long marks its channels bad (last values kept)."},
    {"loop", ValueType::kName, false, 0, 0, nullptr, "none",
     "Transmit, with the driver's `plan`: the plan's loop whose windows the frame is sent in, at "
     "the loop's period and frame offset (no `period` then)."},
    {"class", ValueType::kChoice, false, 0, 0, "periodic|urgent", "periodic with `loop`",
     "Transmit, with a `plan`: `urgent` frames are sent when a value changes, first in the T_1 "
     "frame in which it changed (one of the plan's N_c real-time queues each)."},
    {"signals", ValueType::kList, true, 1, 64, "can-signal", "",
     "The channels in the frame's data bytes."},
};

const KeySpec kSignalKeys[] = {
    {"channel", ValueType::kChannel, true, 0, 0, nullptr, "",
     "The block's address pN.dN.cN (tra/trd for receive frames, twa/twd for transmit)."},
    {"byte", ValueType::kInteger, true, 0, 7, nullptr, "", "The first data byte (0..7)."},
    {"length", ValueType::kInteger, false, 1, 8, nullptr, "1 (float: 4)",
     "Bytes (1..8); byte + length <= 8. A float is 4 (float32) or 8 (float64)."},
    {"type", ValueType::kChoice, false, 0, 0, "unsigned|signed|float", "unsigned",
     "The raw value: an unsigned or two's complement integer, or an IEEE float."},
    {"order", ValueType::kChoice, false, 0, 0, "little|big", "little",
     "Byte order: little (Intel, first byte least significant) or big (Motorola)."},
    {"scale", ValueType::kReal, false, 0, 0, nullptr, "1",
     "Engineering value = raw * scale + offset (transmit applies the inverse, rounded)."},
    {"offset", ValueType::kReal, false, 0, 0, nullptr, "0", "See scale."},
};

const SectionSpec kCanSection{
    "can", "a can driver", "`kind: can`",
    "Raw CAN frames (SocketCAN) with the drives: the EPC group of blocks. One I/O thread "
    "(below the task band) receives the mapped ids and the controller's error frames and "
    "sends what the bridge queued; the bridge, every `period`, publishes each receive "
    "frame's signals (bad after the frame's `timeout`, last value kept) and queues each "
    "transmit frame that is due. After `rtplc stop` every transmit frame is sent once more "
    "with the tasks' safe values. The bus is one link row in `rtplc status`/`stats`.",
    kCanKeys};
const SectionSpec kFrameSection{"can-frame", "a CAN frame", "`receive:` and `transmit:` entries of a can driver",
                                "", kFrameKeys};
const SectionSpec kSignalSection{"can-signal", "a CAN signal", "`signals:` entries of a CAN frame", "",
                                 kSignalKeys};
const SectionSpec kBulkSection{"can-bulk", "a CAN non-RT transfer", "`bulk:` entries of a can driver", "",
                               kBulkKeys};
const SectionSpec* const kSubsections[] = {&kFrameSection, &kSignalSection, &kBulkSection};

void parse_signal(YamlReader& r, const YAML::Node& node, SourcePos where, std::vector<SignalMap>& out) {
  SignalMap m;
  m.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  m.channel_pos = m.pos;
  Fields f = r.fields(node, m.pos, kSignalSection.noun, {kSignalSection.keys});
  if (!f.is_map()) return;
  bool ok = parse_channel_field(r, f, "channel", false, m.addr, m.channel, &m.channel_pos);
  SignalLayout& s = m.layout;
  if (const Field* t = f.get("type")) {
    if (auto v = r.choice(*t)) {
      s.encoding = *v == "signed" ? Encoding::kSigned : *v == "float" ? Encoding::kFloat : Encoding::kUnsigned;
    } else {
      ok = false;
    }
  }
  s.length = s.encoding == Encoding::kFloat ? 4 : 1;
  if (const Field* b = f.get("byte")) {
    if (auto v = r.integer(*b)) s.byte = static_cast<uint8_t>(*v);
    else ok = false;
  }
  if (const Field* l = f.get("length")) {
    if (auto v = r.integer(*l)) {
      s.length = static_cast<uint8_t>(*v);
      if (s.encoding == Encoding::kFloat && s.length != 4 && s.length != 8) {
        r.error(*l, fmt::format("a float is 4 bytes (float32) or 8 (float64), got {}", s.length));
        ok = false;
      }
    } else {
      ok = false;
    }
  }
  if (ok && s.byte + s.length > 8) {
    const Field* at = f.get("length") ? f.get("length") : f.get("byte");
    r.error(*at, fmt::format("bytes {}..{} run past the 8 data bytes of a CAN frame (byte + length <= 8)", s.byte,
                             s.byte + s.length - 1));
    ok = false;
  }
  if (const Field* o = f.get("order")) {
    if (auto v = r.choice(*o)) s.order = *v == "big" ? ByteOrder::kBig : ByteOrder::kLittle;
    else ok = false;
  }
  ok = parse_scaling(r, f, m.pos, s.scale, s.offset) && ok;
  if (ok) out.push_back(std::move(m));
}

void parse_frame(YamlReader& r, const YAML::Node& node, SourcePos where, bool transmit, std::vector<FrameMap>& out) {
  FrameMap fm;
  fm.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  fm.id_pos = fm.pos;
  Fields f = r.fields(node, fm.pos, kFrameSection.noun, {kFrameSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  const Field* id = f.get("id");
  if (id) {
    fm.id_pos = id->pos;
    if (auto t = r.text(*id)) {
      if (auto v = parse_id(*t)) {
        fm.id = *v;
      } else {
        r.error(*id, "'id' expects a CAN identifier (0x181 or 385), got '" + *t + "'");
        ok = false;
      }
    } else {
      ok = false;
    }
  }
  fm.extended = fm.id > kMaxStandardId;
  if (const Field* e = f.get("extended")) {
    if (auto v = r.boolean(*e)) fm.extended = *v;
    else ok = false;
  }
  if (ok && id) {
    if (fm.id > kMaxExtendedId) {
      r.error(*id, fmt::format("CAN id 0x{:X} is beyond 29 bits (at most 0x1FFFFFFF)", fm.id));
      ok = false;
    } else if (!fm.extended && fm.id > kMaxStandardId) {
      r.error(*id, fmt::format("CAN id 0x{:X} does not fit 11 bits (at most 0x7FF); say 'extended: true' for a "
                               "29-bit id",
                               fm.id));
      ok = false;
    }
  }
  for (const char* key : {"period", "on_change"}) {
    if (f.get(key) && !transmit) {
      r.error(*f.get(key), fmt::format("'{}' applies to transmit frames only", key));
      ok = false;
    }
  }
  if (f.get("timeout") && transmit) {
    r.error(*f.get("timeout"), "'timeout' applies to receive frames only");
    ok = false;
  }
  if (const Field* p = f.get("period"); p && transmit) {
    if (auto v = r.duration(*p)) fm.period_s = *v;
    else ok = false;
  }
  if (const Field* p = f.get("timeout"); p && !transmit) {
    if (auto v = r.duration(*p)) fm.timeout_s = *v;
    else ok = false;
  }
  for (const char* key : {"loop", "class"}) {
    if (f.get(key) && !transmit) {
      r.error(*f.get(key), fmt::format("'{}' applies to transmit frames only", key));
      ok = false;
    }
  }
  if (const Field* l = f.get("loop"); l && transmit) {
    if (auto v = r.name(*l)) {
      fm.loop = *v;
      fm.tx_class = FrameMap::Class::kPeriodic;
    } else {
      ok = false;
    }
  }
  if (const Field* c = f.get("class"); c && transmit) {
    if (auto v = r.choice(*c)) {
      if (*v == "urgent") {
        fm.tx_class = FrameMap::Class::kUrgent;
        if (f.get("loop")) {
          r.error(*c, "an urgent frame is sent on change, not in a loop's windows: drop 'loop' or the class");
          ok = false;
        }
      } else if (!f.get("loop")) {
        r.error(*c, "a periodic frame needs 'loop': the plan's loop whose windows it is sent in");
        ok = false;
      }
    } else {
      ok = false;
    }
  }
  if (const Field* p = f.get("period"); p && fm.tx_class == FrameMap::Class::kPeriodic) {
    r.error(*p, "a frame of loop '" + fm.loop + "' is sent at the loop's period from the plan; drop 'period'");
    ok = false;
  }
  if (const Field* c = f.get("on_change"); c && transmit) {
    if (auto v = r.boolean(*c)) fm.on_change = *v;
    else ok = false;
  }
  if (const Field* s = f.get("signals")) {
    if (auto items = r.list(*s)) {
      const size_t before = r.diags().error_count();
      for (const YAML::Node& n : *items) parse_signal(r, n, s->pos, fm.signals);
      ok = ok && r.diags().error_count() == before;
    } else {
      ok = false;
    }
  }
  // Signals may not share a byte: two channels writing the same bits is a typo.
  uint8_t end = 0;
  for (size_t i = 0; i < fm.signals.size(); ++i) {
    const SignalLayout& a = fm.signals[i].layout;
    end = std::max<uint8_t>(end, static_cast<uint8_t>(a.byte + a.length));
    for (size_t j = 0; j < i; ++j) {
      const SignalLayout& b = fm.signals[j].layout;
      if (a.byte < b.byte + b.length && b.byte < a.byte + a.length) {
        r.error(fm.signals[i].pos, fmt::format("bytes {}..{} overlap the signal of {} (line {})", a.byte,
                                               a.byte + a.length - 1, fm.signals[j].channel, fm.signals[j].pos.line));
        ok = false;
      }
    }
  }
  fm.length = transmit ? 8 : end;
  if (const Field* l = f.get("length")) {
    if (auto v = r.integer(*l)) {
      fm.length = static_cast<uint8_t>(*v);
      if (fm.length < end) {
        r.error(*l, fmt::format("the signals need {} data bytes, the frame's length is {}", end, fm.length));
        ok = false;
      }
    } else {
      ok = false;
    }
  }
  if (ok) out.push_back(std::move(fm));
}

void parse_bulk(YamlReader& r, const YAML::Node& node, SourcePos where, std::vector<BulkTransfer>& out) {
  BulkTransfer b;
  b.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  b.id_pos = b.pos;
  Fields f = r.fields(node, b.pos, kBulkSection.noun, {kBulkSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  if (const Field* id = f.get("id")) {
    b.id_pos = id->pos;
    auto t = r.text(*id);
    auto v = t ? parse_id(*t) : std::nullopt;
    if (!v || *v > kMaxExtendedId) {
      if (t) r.error(*id, "'id' expects a CAN identifier (0x5F0 or 1520, at most 0x1FFFFFFF), got '" + *t + "'");
      ok = false;
    } else {
      b.id = *v;
    }
  }
  b.extended = b.id > kMaxStandardId;
  if (const Field* e = f.get("extended")) {
    if (auto v = r.boolean(*e)) b.extended = *v;
    else ok = false;
  }
  if (ok && !b.extended && b.id > kMaxStandardId) {
    r.error(*f.get("id"), fmt::format("CAN id 0x{:X} does not fit 11 bits (at most 0x7FF)", b.id));
    ok = false;
  }
  if (const Field* p = f.get("file")) {
    if (auto v = r.path(*p)) b.file = *v;
    else ok = false;
  }
  if (const Field* e = f.get("every")) {
    if (auto v = r.duration(*e)) b.every_s = *v;
    else ok = false;
  }
  if (ok) out.push_back(std::move(b));
}

// The plan a can link runs on: planned now, so a design that cannot work, or
// frames the plan does not describe, refuse the config (and so the start).
void check_plan(YamlReader& r, const Field& at, const DriverConfig& d, CanSettings& s) {
  auto path = r.path(at);
  if (!path) return;
  auto lp = fieldbus::load_link_plan(*path);
  if (!lp) {
    r.error(at, lp.error());
    return;
  }
  const fieldbus::Plan& p = lp->plan;
  const fieldbus::Design& design = lp->design;
  if (!design.timing || design.timing->layout == fieldbus::FrameLayout::kModbusRtu) {
    r.error(at, "the plan " + *path + " gives no CAN frame layout: a can link's plan needs 'bit_rate' and "
                "'layout: can-11' or 'can-29' in its link, so the frames' wire times are known");
    return;
  }
  const fieldbus::LinkTiming& timing = *design.timing;
  const auto period_ns = static_cast<int64_t>(std::llround(d.period_s * 1e9));
  if (period_ns <= 0 || p.t1 % period_ns != 0) {
    r.error(d.period_pos.line ? d.period_pos : at.pos,
            fmt::format("the driver period ({}) must divide the plan's T_1 = {}: the link schedules at its "
                        "cycles, and every T_1 frame must start on one",
                        fieldbus::format_time(period_ns), fieldbus::format_time(p.t1)));
  }
  int urgent = 0;
  for (const FrameMap& fm : s.transmit) {
    const fieldbus::Nanos wire = timing.packet(fm.length);
    switch (fm.tx_class) {
      case FrameMap::Class::kUnplanned:
        r.error(fm.pos, fmt::format("frame {} is not in the plan: give it 'loop: NAME' (one of {}) or "
                                    "'class: urgent'",
                                    id_text(fm.id, fm.extended), lp->loop_names()));
        break;
      case FrameMap::Class::kPeriodic:
        if (!lp->loop(fm.loop)) {
          r.error(fm.pos, fmt::format("frame {}: the plan has no loop '{}' (its loops: {})", id_text(fm.id, fm.extended),
                                      fm.loop, lp->loop_names()));
        } else if (wire > design.periodic_packet) {
          r.error(fm.pos, fmt::format("frame {} takes {} on the wire, longer than the plan's periodic packet L_p = {}",
                                      id_text(fm.id, fm.extended), fieldbus::format_time(wire),
                                      fieldbus::format_time(design.periodic_packet)));
        }
        break;
      case FrameMap::Class::kUrgent:
        ++urgent;
        if (wire > design.rt_packet) {
          r.error(fm.pos, fmt::format("urgent frame {} takes {} on the wire, longer than the plan's real-time "
                                      "packet L_c = {}",
                                      id_text(fm.id, fm.extended), fieldbus::format_time(wire),
                                      fieldbus::format_time(design.rt_packet)));
        }
        break;
    }
  }
  if (urgent > design.rt_queues) {
    r.error(at, fmt::format("{} urgent frames, but the plan reserves {} real-time queues (N_c): each urgent frame "
                            "is one",
                            urgent, design.rt_queues));
  }
  if (!s.bulk.empty() && timing.packet(8) > p.ln_max) {
    r.error(s.bulk.front().pos, fmt::format("the plan's L_n max = {} is shorter than one 8-byte frame ({}): a "
                                            "non-RT transfer cannot be cut to L_n",
                                            fieldbus::format_time(p.ln_max), fieldbus::format_time(timing.packet(8))));
  }
  s.plan = std::make_shared<const fieldbus::LinkPlan>(std::move(*lp));
}

void parse_can(YamlReader& r, const Fields& f, DriverConfig& out) {
  CanSettings s;
  if (const Field* i = f.get("interface")) {
    if (auto v = r.text(*i)) {
      if (v->size() > 15 || v->find_first_of("/ \t") != std::string::npos) {
        r.error(*i, "'interface' expects a network interface name (can0, vcan0: up to 15 characters, no '/' or "
                    "spaces), got '" + *v + "'");
      } else {
        s.interface = *v;
      }
    }
  }
  if (const Field* e = f.get("error_frames")) {
    if (auto v = r.boolean(*e)) s.error_frames = *v;
  }
  for (const char* key : {"receive", "transmit"}) {
    const Field* list = f.get(key);
    if (!list) continue;
    auto items = r.list(*list);
    if (!items) continue;
    const bool transmit = std::string(key) == "transmit";
    for (const YAML::Node& n : *items) parse_frame(r, n, list->pos, transmit, transmit ? s.transmit : s.receive);
  }
  for (auto* frames : {&s.receive, &s.transmit}) {
    std::map<std::pair<uint32_t, bool>, SourcePos> ids;
    std::map<std::string, SourcePos> outputs;
    for (const FrameMap& fm : *frames) {
      auto [it, fresh] = ids.emplace(std::pair{fm.id, fm.extended}, fm.id_pos);
      if (!fresh) {
        r.error(fm.id_pos, fmt::format("CAN id 0x{:X} is listed twice (first at line {})", fm.id, it->second.line));
      }
      // (An input mapped twice is the loader's "one source per input" error.)
      if (frames != &s.transmit) continue;
      for (const SignalMap& m : fm.signals) {
        auto [c, first] = outputs.emplace(m.channel, m.channel_pos);
        if (!first) {
          r.error(m.channel_pos,
                  fmt::format("output {} is sent in two frames (first at line {})", m.channel, c->second.line));
        }
      }
    }
  }
  if (const Field* b = f.get("bulk")) {
    if (auto items = r.list(*b)) {
      for (const YAML::Node& n : *items) parse_bulk(r, n, b->pos, s.bulk);
    }
    if (!f.get("plan")) r.error(*b, "'bulk' needs the driver's 'plan': a non-RT transfer uses what the plan leaves");
    for (const BulkTransfer& t : s.bulk) {
      for (const FrameMap& fm : s.transmit) {
        if (fm.id == t.id && fm.extended == t.extended) {
          r.error(t.id_pos, fmt::format("CAN id 0x{:X} is already a transmit frame (line {})", t.id, fm.id_pos.line));
        }
      }
    }
  }
  if (const Field* p = f.get("plan")) {
    check_plan(r, *p, out, s);
  } else {
    for (const FrameMap& fm : s.transmit) {
      if (fm.tx_class != FrameMap::Class::kUnplanned) {
        r.error(fm.pos, fmt::format("frame {} has a 'loop' or 'class', which needs the driver's 'plan'",
                                    id_text(fm.id, fm.extended)));
      }
    }
  }
  if (!f.get("receive") && !f.get("transmit") && f.get("interface")) {
    r.error(*f.get("interface"), "a can driver needs a 'receive' or a 'transmit' list (it maps no frames)");
  }
  out.settings = std::move(s);
}

std::string can_doc() {
  return "Example: a drive's status frame into `tra(p0, d1, c0, ...)`/`trd(p0, d1, c1, ...)`, its "
         "command frame from `twa`/`twd`:\n\n```yaml\ndrivers:\n  - kind: can\n    name: epc\n"
         "    period: 5ms\n    interface: can0\n    receive:\n      - id: 0x181\n        timeout: 100ms\n"
         "        signals:\n          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, scale: 0.1}\n"
         "          - {channel: p0.d1.c1, byte: 2}\n    transmit:\n      - id: 0x201\n        period: 20ms\n"
         "        signals:\n          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, scale: 0.1}\n"
         "          - {channel: p0.d1.c1, byte: 2}\n```\n\n"
         "See docs/can.md for the link statistics, `rtplc can dump` and the tests.\n";
}

ChannelClaim claim(const DriverConfig& d, const SignalMap& m, BindingDir dir) {
  return {channel_key(dir, IoGroup::kEpc, 0, m.addr.p, m.addr.d, m.addr.c), fmt::format("{}.{}", d.name, m.channel),
          m.channel_pos};
}

// Each receive signal provides a channel (region order: frames, then their
// signals, as listed); each transmit signal consumes a task output; the bus is
// one link row.
DriverClaims can_claims(const DriverConfig& d) {
  const CanSettings& s = settings_of(d);
  DriverClaims c;
  for (const FrameMap& fm : s.receive) {
    for (const SignalMap& m : fm.signals) {
      c.provides.push_back(claim(d, m, BindingDir::kInput));
      c.provides.back().max_age_ns = static_cast<int64_t>(fm.timeout_s * 1e9);  // the frame's timeout
    }
  }
  for (const FrameMap& fm : s.transmit) {
    for (const SignalMap& m : fm.signals) c.consumes.push_back(claim(d, m, BindingDir::kOutput));
  }
  c.links = 1;
  return c;
}

}  // namespace

std::optional<uint32_t> parse_id(const std::string& text) {
  if (text.empty() || text[0] == '-' || text[0] == '+') return std::nullopt;
  const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  const char* begin = text.c_str() + (hex ? 2 : 0);
  if (*begin == '\0') return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(begin, &end, hex ? 16 : 10);
  if (errno != 0 || *end != '\0' || v > 0xFFFFFFFFull) return std::nullopt;
  return static_cast<uint32_t>(v);
}

const CanSettings& settings_of(const DriverConfig& d) { return settings_as<CanSettings>(d); }

const DriverKind kConfigKind{
    "can",         "raw CAN frames (SocketCAN) with drives, for tra/trd/twa/twd",
    &kCanSection,  kSubsections,
    &parse_can,    &can_claims,
    &can_doc,
};

}  // namespace rtplc::can
