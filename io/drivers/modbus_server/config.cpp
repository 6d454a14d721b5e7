// The `modbus-server` driver kind of the configuration (issue 9, item 2): where
// the server listens, whom it serves, and which channels it exposes at which
// items. Every value and every overlap is checked here with a position; the
// labels themselves are the programs' and are resolved when the driver is
// created (driver.cpp), with the entry's line in the message.
#include "io/drivers/modbus_server/config.h"

#include <arpa/inet.h>

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <map>
#include <string>

#include "config/map_entries.h"
#include "config/yaml_reader.h"

namespace rtplc::modbus_server {
using namespace config;
using modbus::ItemType;
using modbus::Table;
namespace {

const KeySpec kServerKeys[] = {
    {"bind", ValueType::kText, false, 0, 0, "numeric IPv4", "127.0.0.1",
     "The address the server listens on. Loopback by default: serving another network is a "
     "decision, made here and in `allow`. `0.0.0.0` listens on every interface."},
    {"port", ValueType::kInteger, false, 1, 65535, nullptr, "502",
     "The TCP port; 502 is Modbus's (below 1024: root or CAP_NET_BIND_SERVICE)."},
    {"units", ValueType::kList, false, 1, 256, "unit id (0..255)", "every unit id",
     "The unit ids (0..255) answered, e.g. `[1]`; a request to another gets exception 11."},
    {"max_clients", ValueType::kInteger, false, 1, 256, nullptr, "16",
     "At most this many clients at once; one more is disconnected at once and counted."},
    {"timeout", ValueType::kDuration, false, 0.1, 86400, nullptr, "60s",
     "A client that sends nothing this long is disconnected (it may reconnect)."},
    {"allow", ValueType::kList, false, 1, 256, "IPv4 address or network (10.0.0.0/24)", "127.0.0.0/8",
     "The client addresses and networks served, e.g. `[127.0.0.1, 10.0.0.0/24]`; any other "
     "client is disconnected at once, counted and logged."},
    {"expose", ValueType::kList, true, 1, 4096, "modbus-expose", "",
     "The channels served, each at an item of one of the four tables."},
    {"writable", ValueType::kList, false, 1, 4096, "a set-point label", "(none: read-only)",
     "The set-points a client may write, e.g. `[Setpoint]`; each must be exposed in `hr` or "
     "`coil`. Without it the server is read-only: every write is answered with exception 2. "
     "Modbus TCP has no authentication, so every client `allow` admits may write these; the "
     "control socket, by contrast, is its owner's."},
};

const KeySpec kExposeKeys[] = {
    {"label", ValueType::kText, true, 0, 0, "a channel label", "",
     "The channel, by the label the program gives it (an input, an output or a set-point)."},
    {"table", ValueType::kChoice, true, 0, 0, "ir|hr|di|coil", "",
     "Input registers or discrete inputs are read-only; holding registers and coils are "
     "writable for set-points (and read-only for inputs and outputs)."},
    {"address", ValueType::kInteger, true, 0, 65535, nullptr, "", "The 0-based protocol address."},
    {"type", ValueType::kChoice, false, 0, 0, "u16|i16|u32|i32|f32", "u16",
     "Registers only; u32, i32 and f32 take two registers."},
    {"word_order", ValueType::kChoice, false, 0, 0, "high_first|low_first", "high_first",
     "Two-register types: which word comes first."},
    {"scale", ValueType::kReal, false, 0, 0, nullptr, "1",
     "Registers only: raw = (value - offset) / scale, rounded for integer types; a write "
     "applies value = raw * scale + offset."},
    {"offset", ValueType::kReal, false, 0, 0, nullptr, "0", "See scale."},
};

const SectionSpec kServerSection{
    "modbus-server", "a modbus-server driver", "`kind: modbus-server`",
    "A Modbus TCP server for a SCADA or HMI: it serves the exposed channels straight from the "
    "process image, many clients at once, on its own thread below the task band. A read "
    "covering a channel whose quality is not good (or forced) is answered with exception 4, "
    "so a value we cannot vouch for never reaches SCADA as a number. The set-points listed in "
    "`writable` (exposed in holding registers or coils) may be written (FC 5, 6, 15, 16) and "
    "go through the path of `rtplc set`: checked, retained, logged; a value the runtime "
    "refuses gets exception 3. Nothing else is ever written from the network, and without "
    "`writable` nothing at all. Its link row counts clients and requests. See docs/modbus.md.",
    kServerKeys};
const SectionSpec kExposeSection{"modbus-expose", "an exposed channel",
                                 "`expose:` entries of a modbus-server driver", "", kExposeKeys};
const SectionSpec* const kSubsections[] = {&kExposeSection};

bool parse_ipv4(const std::string& text, uint32_t& out) {
  in_addr a{};
  if (inet_pton(AF_INET, text.c_str(), &a) != 1) return false;
  out = ntohl(a.s_addr);
  return true;
}

std::string scalar_text(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : std::string(); }

SourcePos pos_or(const YAML::Node& n, SourcePos fallback) {
  const SourcePos p = YamlReader::pos(n);
  return p.line ? p : fallback;
}

void parse_item(YamlReader& r, const YAML::Node& node, SourcePos where, ServerSettings& out) {
  ExposeItem e;
  e.pos = e.label_pos = pos_or(node, where);
  Fields f = r.fields(node, e.pos, kExposeSection.noun, {kExposeSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  if (const Field* l = f.get("label")) {
    e.label_pos = l->pos;
    if (auto v = r.text(*l)) {
      if (v->size() >= 32) {
        r.error(*l, fmt::format("'{}' is longer than a channel label can be (31 characters)", *v));
        ok = false;
      }
      e.label = *v;
    } else {
      ok = false;
    }
  } else {
    ok = false;
  }
  std::string table = "hr";
  if (const Field* t = f.get("table")) {
    if (auto v = r.choice(*t)) table = *v;
    else ok = false;
  } else {
    ok = false;
  }
  std::string type = "u16";
  if (const Field* t = f.get("type")) {
    if (auto v = r.choice(*t)) type = *v;
    else ok = false;
  }
  int64_t address = 0;
  if (const Field* a = f.get("address")) {
    if (auto v = r.integer(*a)) address = *v;
    else ok = false;
  }
  const bool bits = table == "di" || table == "coil";
  for (const char* key : {"type", "word_order", "scale", "offset"}) {
    if (f.get(key) && bits) {
      r.error(*f.get(key), fmt::format("'{}' applies to registers (ir, hr) only: a {} is one bit", key, table));
      ok = false;
    }
  }
  if (!ok) return;
  auto a = modbus::parse_address(bits ? fmt::format("{}:0", table) : fmt::format("{}:0:{}", table, type));
  if (!a) return;  // the choices above make every spelling valid
  e.item = *a;
  e.item.address = static_cast<uint16_t>(address);
  if (const Field* w = f.get("word_order")) {
    if (auto v = r.choice(*w)) {
      if (modbus::width(e.item) != 2) {
        r.error(*w, "'word_order' applies to two-register types (u32, i32, f32) only");
        ok = false;
      }
      e.item.swapped = *v == "low_first";
    } else {
      ok = false;
    }
  }
  if (address + modbus::width(e.item) > 65536) {
    r.error(*f.get("address"), "a two-register value needs address + 1 <= 65535");
    ok = false;
  }
  ok &= parse_scaling(r, f, e.pos, e.scale, e.offset);
  if (ok) out.items.push_back(std::move(e));
}

void parse_server(YamlReader& r, const Fields& f, DriverConfig& out) {
  ServerSettings s;
  const Field* bind = f.get("bind");
  if (bind) {
    if (auto v = r.text(*bind)) {
      uint32_t ip = 0;
      if (parse_ipv4(*v, ip)) {
        s.bind = *v;
      } else {
        r.error(*bind, "'bind' must be a numeric IPv4 address (127.0.0.1, 0.0.0.0, 10.0.0.5), got '" + *v + "'");
      }
    }
  }
  if (const Field* p = f.get("port")) {
    if (auto v = r.integer(*p)) s.port = static_cast<uint16_t>(*v);
  }
  if (const Field* m = f.get("max_clients")) {
    if (auto v = r.integer(*m)) s.max_clients = static_cast<uint32_t>(*v);
  }
  if (const Field* t = f.get("timeout")) {
    if (auto v = r.duration(*t)) s.timeout_s = *v;
  }
  if (const Field* u = f.get("units")) {
    if (auto items = r.list(*u)) {
      for (const YAML::Node& n : *items) {
        const SourcePos at = pos_or(n, u->pos);
        const std::string text = scalar_text(n);
        unsigned id = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
        if (text.empty() || ec != std::errc() || end != text.data() + text.size() || id > 255) {
          r.error(at, "a unit id is a whole number 0..255, got " + YamlReader::describe_node(n));
          continue;
        }
        if (std::find(s.units.begin(), s.units.end(), id) != s.units.end()) {
          r.error(at, fmt::format("unit {} is listed twice", id));
          continue;
        }
        s.units.push_back(static_cast<uint8_t>(id));
      }
    }
  }
  if (const Field* a = f.get("allow")) {
    if (auto items = r.list(*a)) {
      for (const YAML::Node& n : *items) {
        AllowRule rule;
        const std::string text = scalar_text(n);
        if (!parse_allow(text, rule)) {
          r.error(pos_or(n, a->pos), "'allow' takes numeric IPv4 addresses (10.0.0.7) or networks "
                                     "(10.0.0.0/24), got " + YamlReader::describe_node(n));
          continue;
        }
        s.allow.push_back(rule);
        s.allow_text += (s.allow_text.empty() ? "" : " ") + text;
      }
    }
  } else {
    AllowRule loopback;
    parse_allow("127.0.0.0/8", loopback);
    s.allow.push_back(loopback);
    s.allow_text = "127.0.0.0/8";
    if (bind && s.bind.rfind("127.", 0) != 0) {
      r.warning(bind->pos, "without 'allow' only loopback clients are served; list the SCADA's "
                           "addresses (allow: [10.0.0.0/24]) to serve them on " + s.bind);
    }
  }
  if (const Field* x = f.get("expose")) {
    if (auto items = r.list(*x)) {
      for (const YAML::Node& n : *items) parse_item(r, n, x->pos, s);
    }
  }
  if (const Field* w = f.get("writable")) {
    if (auto items = r.list(*w)) {
      for (const YAML::Node& n : *items) {
        const std::string label = scalar_text(n);
        const SourcePos at = pos_or(n, w->pos);
        bool exposed = false;
        for (const ExposeItem& e : s.items) exposed |= e.label == label && modbus::is_writable(e.item.table);
        if (!exposed) {
          r.error(at, "'writable' names \"" + label + "\", which no `expose` entry serves in hr or coil");
          continue;
        }
        s.writable.push_back(label);
        s.writable_pos.push_back(at);
      }
    }
  }
  // One register or bit, one item; one channel may be exposed at several.
  std::map<uint32_t, const ExposeItem*> owner;  // table << 16 | address
  for (const ExposeItem& e : s.items) {
    for (uint16_t w = 0; w < modbus::width(e.item); ++w) {
      const uint32_t key = static_cast<uint32_t>(e.item.table) << 16 | (e.item.address + w);
      auto [it, fresh] = owner.emplace(key, &e);
      if (!fresh) {
        r.error(e.pos, fmt::format("{} {} is already {}'s (line {})", modbus::table_name(e.item.table),
                                   e.item.address + w, it->second->label, it->second->pos.line));
        break;
      }
    }
  }
  out.settings = std::move(s);
}

std::string server_doc() {
  return "Example: SCADA on 10.0.0.0/24 reads the loop's process value and output as floats "
         "and writes its set-point:\n\n```yaml\ndrivers:\n  - kind: modbus-server\n    name: scada\n"
         "    bind: 0.0.0.0\n    allow: [127.0.0.1, 10.0.0.0/24]\n    expose:\n"
         "      - {label: ProcVal, table: ir, address: 0, type: f32}\n"
         "      - {label: ManiVal, table: ir, address: 2, type: f32}\n"
         "      - {label: Setpoint, table: hr, address: 0, type: f32}\n"
         "      - {label: Setpoint, table: hr, address: 10, type: i16, scale: 0.1}\n```\n\n"
         "See docs/modbus.md for the exceptions it answers and how writes are checked.\n";
}

// A server exchanges nothing with the tasks through its own region: it reads
// the image like `rtplc monitor` does, and sets set-points through the runtime.
DriverClaims server_claims(const DriverConfig&) {
  DriverClaims c;
  c.links = 1;
  return c;
}

}  // namespace

bool ServerSettings::allows(uint32_t ip) const {
  return std::any_of(allow.begin(), allow.end(), [&](const AllowRule& a) { return a.matches(ip); });
}

bool ServerSettings::answers(uint8_t unit) const {
  return units.empty() || std::find(units.begin(), units.end(), unit) != units.end();
}

bool parse_allow(const std::string& text, AllowRule& out) {
  const size_t slash = text.find('/');
  uint32_t ip = 0;
  if (!parse_ipv4(text.substr(0, slash), ip)) return false;
  unsigned bits = 32;
  if (slash != std::string::npos) {
    const std::string b = text.substr(slash + 1);
    const auto [end, ec] = std::from_chars(b.data(), b.data() + b.size(), bits);
    if (b.empty() || ec != std::errc() || end != b.data() + b.size() || bits > 32) return false;
  }
  out.mask = bits == 0 ? 0 : ~uint32_t{0} << (32 - bits);
  out.network = ip & out.mask;
  return true;
}

const ServerSettings& settings_of(const DriverConfig& d) { return settings_as<ServerSettings>(d); }

const DriverKind kConfigKind{
    "modbus-server",  "a Modbus TCP server exposing channels to SCADA and HMIs",
    &kServerSection,  kSubsections,
    &parse_server,    &server_claims,
    &server_doc,
};

}  // namespace rtplc::modbus_server
