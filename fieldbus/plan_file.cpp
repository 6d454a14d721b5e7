// Plan file loader (see plan_file.h). One pass collects every problem it can;
// nothing throws past this file.
#include "fieldbus/plan_file.h"

#include "common/files.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "config/yaml_reader.h"
#include "fieldbus/link_timing.h"

namespace rtplc::fieldbus {
namespace {

using config::Field;
using config::Fields;
using config::KeySpec;
using config::ValueType;
using config::YamlReader;

constexpr double kNone = 0;
constexpr double kMaxBytes = 250;

const KeySpec kTopKeys[] = {
    {"link", ValueType::kSection, true, kNone, kNone, nullptr, "", "The bus: nodes and timing."},
    {"periodic", ValueType::kSection, true, kNone, kNone, nullptr, "", "The loops' packet."},
    {"realtime", ValueType::kSection, false, kNone, kNone, nullptr, "(none)", "Sporadic alarms."},
    {"nonrt", ValueType::kSection, false, kNone, kNone, nullptr, "(L_n max)", "Files, config."},
    {"loops", ValueType::kList, true, 1, kMaxLoops, "loop", "", "The control loops."},
};
const KeySpec kLinkKeys[] = {
    {"nodes", ValueType::kInteger, true, -1e9, 1e9, nullptr, "", "N"},
    {"server_overhead", ValueType::kDuration, false, kNone, kNone, nullptr, "", "sigma"},
    {"server_frame", ValueType::kInteger, false, 0, kMaxBytes, nullptr, "", "poll bytes"},
    {"bit_rate", ValueType::kText, false, kNone, kNone, nullptr, "", "bits per second"},
    {"layout", ValueType::kChoice, false, kNone, kNone, "can-11|can-29|modbus-rtu", "", ""},
    {"access", ValueType::kChoice, false, kNone, kNone, "polling|token", "polling", ""},
    {"frame", ValueType::kDuration, false, kNone, kNone, nullptr, "", "T_1"},
};
const KeySpec kPeriodicKeys[] = {
    {"packet", ValueType::kDuration, false, kNone, kNone, nullptr, "", "L_p"},
    {"bytes", ValueType::kInteger, false, 0, kMaxBytes, nullptr, "", "payload"},
};
const KeySpec kRealtimeKeys[] = {
    {"queues", ValueType::kInteger, true, 0, kMaxNodes, nullptr, "", "N_c"},
    {"packet", ValueType::kDuration, false, kNone, kNone, nullptr, "", "L_c"},
    {"bytes", ValueType::kInteger, false, 0, kMaxBytes, nullptr, "", "payload"},
    {"rate", ValueType::kReal, false, kNone, kNone, nullptr, "10", "arrivals/s per queue"},
};
const KeySpec kNonrtKeys[] = {
    {"packet", ValueType::kDuration, false, kNone, kNone, nullptr, "", "L_n"},
    {"bytes", ValueType::kInteger, false, 0, kMaxBytes, nullptr, "", "payload"},
    {"rate", ValueType::kText, false, kNone, kNone, nullptr, "saturated", "packets/s per node"},
};
const KeySpec kLoopKeys[] = {
    {"name", ValueType::kName, true, kNone, kNone, nullptr, "", ""},
    {"period", ValueType::kDuration, false, kNone, kNone, nullptr, "", "T_i"},
    {"max_delay", ValueType::kDuration, false, kNone, kNone, nullptr, "", "Phi_i"},
    {"sensor", ValueType::kInteger, false, 0, kMaxNodes - 1, nullptr, "", "node"},
    {"controller", ValueType::kInteger, false, 0, kMaxNodes - 1, nullptr, "", "node"},
};

SourcePos to_pos(const YAML::Mark& m) {
  if (m.line < 0 || m.column < 0) return {1, 1};
  return {static_cast<uint32_t>(m.line) + 1, static_cast<uint32_t>(m.column) + 1};
}

std::optional<Nanos> read_time(YamlReader& r, const Field& f) {
  const std::string key = f.spec->key;
  const std::string expected = "a time such as 100us, 5ms, 0.1s or 0.002 (seconds)";
  if (!f.value.IsDefined() || f.value.IsNull() || !f.value.IsScalar()) {
    r.error(f, "'" + key + "' expects " + expected + ", got " + YamlReader::describe_node(f.value));
    return std::nullopt;
  }
  auto v = parse_time(f.value.Scalar());
  if (!v) {
    r.error(f, "'" + key + "' expects " + expected + ", got " + YamlReader::describe_node(f.value));
    return std::nullopt;
  }
  if (*v <= 0) {
    r.error(f, "'" + key + "' must be longer than 0");
    return std::nullopt;
  }
  return v;
}

// The pieces of the link the packet sections need.
struct LinkContext {
  std::optional<LinkTiming> timing;
  bool ok = true;  // false: the link had errors, so byte sizes are not checked again
};

// `packet: 100us` or `bytes: 8`, exactly one (both optional when `required` is false).
std::optional<Nanos> read_packet(YamlReader& r, const Fields& f, const LinkContext& link,
                                 std::string_view noun, bool required, bool& given) {
  const Field* pk = f.get("packet");
  const Field* by = f.get("bytes");
  given = pk || by;
  if (pk && by) {
    r.error(by->key_pos, std::string(noun) + " gives both 'packet' and 'bytes'; keep one",
            YamlReader::width(by->key));
    return std::nullopt;
  }
  if (pk) return read_time(r, *pk);
  if (by) {
    auto n = r.integer(*by);
    if (!n) return std::nullopt;
    if (!link.timing) {
      if (link.ok) {
        r.error(*by,
                "'bytes' needs the link's 'bit_rate' and 'layout' to become a time; give "
                "'packet: 100us' instead");
      }
      return std::nullopt;
    }
    if (*n > max_payload(link.timing->layout)) {
      r.error(*by, "a " + std::string(to_string(link.timing->layout)) + " packet carries at most " +
                       std::to_string(max_payload(link.timing->layout)) + " data bytes, got " +
                       std::to_string(*n));
      return std::nullopt;
    }
    return link.timing->packet(static_cast<int>(*n));
  }
  if (required) {
    r.error(f.where(), std::string(noun) +
                           " needs 'packet' (a time such as 100us) or 'bytes' "
                           "(with the link's bit_rate and layout)");
  }
  return std::nullopt;
}

LinkContext parse_link(YamlReader& r, const Field& section, Design& d) {
  LinkContext ctx;
  const size_t errors_before = r.diags().error_count();
  Fields f = r.fields(section.value, section.pos, "the link", {kLinkKeys});
  if (const Field* x = f.get("nodes")) {
    if (auto n = r.integer(*x)) {
      if (*n <= 0) {
        r.error(*x, "'nodes' is " + std::to_string(*n) +
                        ": the server has nobody to visit; a loop needs at least two nodes "
                        "(its sensor and its controller)");
      } else if (*n == 1) {
        r.error(*x,
                "'nodes' is 1; a loop needs two nodes (its sensor and its controller send in "
                "the same frame)");
      } else if (*n > kMaxNodes) {
        r.error(*x, "'nodes' is " + std::to_string(*n) +
                        "; the PB byte holds a 7-bit node "
                        "address, so a link has at most " +
                        std::to_string(kMaxNodes) + " nodes");
      } else {
        d.nodes = static_cast<int>(*n);
      }
    }
  }
  const Field* rate = f.get("bit_rate");
  const Field* layout = f.get("layout");
  std::optional<double> bits;
  std::optional<FrameLayout> lay;
  if (rate) {
    if (auto s = r.text(*rate)) {
      bits = parse_bit_rate(*s);
      if (!bits) {
        r.error(*rate,
                "'bit_rate' expects bits per second such as 500kbit/s, 1Mbit/s or 19200, "
                "got " +
                    YamlReader::describe_node(rate->value));
      }
    }
  }
  if (layout) {
    if (auto s = r.choice(*layout)) lay = parse_layout(*s);
  }
  if (rate && !layout)
    r.error(rate->key_pos, "'bit_rate' needs 'layout' (can-11, can-29 or modbus-rtu)");
  if (layout && !rate) r.error(layout->key_pos, "'layout' needs 'bit_rate' (such as 500kbit/s)");
  if (bits && lay) {
    ctx.timing = LinkTiming{*lay, *bits};
    d.link_text = ctx.timing->describe();
    d.timing = ctx.timing;
  }
  const Field* so = f.get("server_overhead");
  const Field* sf = f.get("server_frame");
  if (so) {
    if (auto v = read_time(r, *so)) d.server_overhead = *v;
    if (sf) r.error(sf->key_pos, "give 'server_overhead' or 'server_frame', not both");
  } else if (sf) {
    if (auto n = r.integer(*sf)) {
      if (!layout) {
        r.error(*sf, "'server_frame' needs 'bit_rate' and 'layout' to become a time");
      } else if (ctx.timing) {
        if (*n > max_payload(ctx.timing->layout)) {
          r.error(*sf, "a " + std::string(to_string(ctx.timing->layout)) +
                           " server frame carries at most " +
                           std::to_string(max_payload(ctx.timing->layout)) + " bytes");
        } else {
          d.server_overhead = ctx.timing->server_overhead(static_cast<int>(*n));
        }
      }
    }
  } else if (ctx.timing) {
    const int def = ctx.timing->layout == FrameLayout::kModbusRtu ? kModbusRequestChars : 0;
    d.server_overhead = ctx.timing->server_overhead(def);
  } else if (!layout && !rate) {
    r.error(f.where(),
            "the link needs 'server_overhead' (a time such as 20us), or 'bit_rate' and "
            "'layout' to compute it");
  }
  if (ctx.timing) d.nonrt_min_packet = ctx.timing->packet(0) > 0 ? ctx.timing->packet(0) : 1;
  if (const Field* x = f.get("access")) {
    if (auto s = r.choice(*x)) d.access = *s == "token" ? Access::kTokenPassing : Access::kPolling;
  }
  if (const Field* x = f.get("frame")) d.frame = read_time(r, *x);
  ctx.ok = r.diags().error_count() == errors_before;
  return ctx;
}

void parse_loop(YamlReader& r, const YAML::Node& n, SourcePos list_pos, Design& d) {
  const SourcePos where = YamlReader::pos(n).line ? YamlReader::pos(n) : list_pos;
  Fields f = r.fields(n, where, "a loop", {kLoopKeys});
  if (!f.is_map()) return;
  LoopSpec l;
  l.pos = f.where();
  if (const Field* x = f.get("name")) {
    if (auto s = r.name(*x)) {
      for (const LoopSpec& other : d.loops) {
        if (other.name == *s) {
          r.error(*x, "a second loop named '" + *s + "'; loop names must be unique");
          r.note(other.pos, "the first one is here");
        }
      }
      l.name = *s;
    }
  }
  const Field* per = f.get("period");
  const Field* phi = f.get("max_delay");
  if (per && phi) {
    r.error(phi->key_pos,
            "a loop gives 'period' or 'max_delay', not both: with a fixed period "
            "there is nothing left for the planner to choose",
            YamlReader::width(phi->key));
  } else if (per) {
    l.period = read_time(r, *per);
  } else if (phi) {
    l.max_delay = read_time(r, *phi);
  } else {
    r.error(f.where(),
            "a loop needs 'period' (fixed sampling period) or 'max_delay' (the bound "
            "Phi_i the planner picks a period for)");
  }
  for (const char* key : {"sensor", "controller"}) {
    const Field* x = f.get(key);
    if (!x) continue;
    auto v = r.integer(*x);
    if (!v) continue;
    if (d.nodes > 0 && *v >= d.nodes) {
      r.error(*x, "'" + std::string(key) + "' is node " + std::to_string(*v) +
                      " but the link's nodes are 0 to " + std::to_string(d.nodes - 1));
      continue;
    }
    (std::string_view(key) == "sensor" ? l.sensor_node : l.controller_node) = static_cast<int>(*v);
  }
  d.loops.push_back(std::move(l));
}

void parse_document(const std::string& text, PlanFile& out) {
  std::istringstream in(text);
  const YAML::Node root = YAML::Load(in);
  YamlReader r(out.diags, "");
  if (!root.IsDefined() || root.IsNull()) {
    r.error({1, 1}, "the plan file is empty; it needs 'link', 'periodic' and 'loops'");
    return;
  }
  if (!root.IsMap()) {
    r.error(YamlReader::pos(root).line ? YamlReader::pos(root) : SourcePos{1, 1},
            "the plan file must be a map with 'link', 'periodic' and 'loops', got " +
                YamlReader::describe_node(root),
            YamlReader::width(root));
    return;
  }
  Design d;
  Fields top = r.fields(root, {1, 1}, "the plan file", {kTopKeys});
  LinkContext link;
  link.ok = false;
  if (const Field* x = top.get("link")) link = parse_link(r, *x, d);
  if (const Field* x = top.get("periodic")) {
    Fields f = r.fields(x->value, x->pos, "the periodic traffic", {kPeriodicKeys});
    bool given = false;
    if (f.is_map() || x->value.IsNull()) {
      if (auto v = read_packet(r, f, link, "the periodic traffic", true, given))
        d.periodic_packet = *v;
    }
  }
  if (const Field* x = top.get("realtime")) {
    Fields f = r.fields(x->value, x->pos, "the real-time traffic", {kRealtimeKeys});
    if (f.is_map()) {
      if (const Field* q = f.get("queues")) {
        if (auto v = r.integer(*q)) d.rt_queues = static_cast<int>(*v);
      }
      bool given = false;
      if (auto v = read_packet(r, f, link, "the real-time traffic", d.rt_queues > 0, given)) {
        d.rt_packet = *v;
      }
      if (const Field* q = f.get("rate")) {
        if (auto v = r.real(q->value, q->pos, "'rate'")) {
          if (*v < 0)
            r.error(*q, "'rate' must be 0 or more arrivals per second");
          else
            d.rt_rate = *v;
        }
      }
    }
  }
  if (const Field* x = top.get("nonrt")) {
    Fields f = r.fields(x->value, x->pos, "the non-real-time traffic", {kNonrtKeys});
    if (f.is_map() || x->value.IsNull()) {
      bool given = false;
      if (auto v = read_packet(r, f, link, "the non-real-time traffic", false, given)) {
        d.nonrt_packet = *v;
      }
      if (const Field* q = f.get("rate")) {
        if (auto s = r.text(*q)) {
          if (*s == "saturated") {
            d.nonrt_rate = -1;
          } else if (auto v = config::parse_real(*s); v && *v >= 0) {
            d.nonrt_rate = *v;
          } else {
            r.error(*q,
                    "'rate' expects packets per second per node (such as 200) or "
                    "'saturated', got " +
                        YamlReader::describe_node(q->value));
          }
        }
      }
    }
  }
  if (const Field* x = top.get("loops")) {
    if (auto items = r.list(*x)) {
      for (const YAML::Node& n : *items) parse_loop(r, n, x->pos, d);
    }
  }
  if (!out.diags.has_errors()) out.design = std::move(d);
}

}  // namespace

PlanFile parse_plan_file(std::string_view yaml, const std::string& file_name) {
  PlanFile out;
  out.file = file_name;
  out.source = std::string(yaml);
  try {
    parse_document(out.source, out);
  } catch (const YAML::ParserException& e) {
    out.diags.error(to_pos(e.mark), "YAML syntax error: " + e.msg);
  } catch (const std::exception& e) {
    out.diags.error({}, std::string("cannot read the plan file: ") + e.what());
  }
  if (out.diags.has_errors()) out.design.reset();
  return out;
}

PlanFile load_plan_file(const std::string& path) {
  PlanFile out;
  out.file = path;
  Result<std::string> text = read_file_bounded(path, size_t{1} << 20);
  if (!text) {
    // The diagnostic is rendered after "PATH:", so say only why.
    const std::string why = file_error_reason(path, text.error());
    out.diags.error({}, is_missing_file_error(text.error()) ? std::string("plan file not found")
                        : why.rfind("is ", 0) == 0       ? "the plan file " + why
                                                         : "the plan file: " + why);
    return out;
  }
  return parse_plan_file(*text, path);
}

}  // namespace rtplc::fieldbus
