// The `sparkplug` driver kind of the configuration: every key checked here with
// its position. Labels are the programs' and are resolved when the driver is
// created (driver.cpp), with the entry's line in the message.
#include "io/drivers/sparkplug/config.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>

#include "config/yaml_reader.h"

namespace rtplc::sparkplug {
using namespace config;
namespace {

const KeySpec kKeys[] = {
    {"broker", ValueType::kText, true, 0, 0, "host:port or mqtt(s)://host:port", "",
     "The MQTT broker: `127.0.0.1:1883`, `mqtt://broker.plant:1883`, or `mqtts://broker.plant:8883` "
     "for TLS (then `ca`, and `cert`/`key` for a client certificate). The port defaults to 1883 "
     "(8883 for mqtts)."},
    {"ca", ValueType::kPath, false, 0, 0, nullptr, "(the system's)", "TLS: the CA certificate file that signed the broker's."},
    {"cert", ValueType::kPath, false, 0, 0, nullptr, "(none)", "TLS: this box's client certificate (PEM)."},
    {"key", ValueType::kPath, false, 0, 0, nullptr, "(none)", "TLS: the client certificate's key (PEM)."},
    {"username", ValueType::kText, false, 0, 0, nullptr, "(none)", "MQTT user name, for brokers with ACLs."},
    {"password", ValueType::kText, false, 0, 0, nullptr, "(none)",
     "MQTT password. Over plain `mqtt://` it travels in clear text: use mqtts off the box."},
    {"keepalive", ValueType::kDuration, false, 1, 3600, nullptr, "10s",
     "MQTT keep-alive: a link silent 1.5 times this long is taken as lost, by the broker (which "
     "then publishes the NDEATH will) and by the node (which reconnects)."},
    {"mqtt", ValueType::kChoice, false, 0, 0, "5|3.1.1", "5",
     "The MQTT version. With 5 the node also sees that a command arriving live was published "
     "retained, and refuses it; 3.1.1 (for old brokers) shows that only for a command the broker "
     "kept, at subscribe time."},
    {"group", ValueType::kText, true, 0, 0, "Sparkplug group id", "",
     "The Sparkplug group id (`Plant1`): topics are spBv1.0/GROUP/..."},
    {"node", ValueType::kText, true, 0, 0, "Sparkplug edge node id", "",
     "This box's edge node id (`rtplc-01`), unique in its group. The devices below it are the tasks, "
     "by task name."},
    {"primary_host", ValueType::kText, false, 0, 0, "Sparkplug host id", "(none)",
     "The primary host application's id (`scada`): the node publishes its births only while that "
     "host's STATE says online, and keeps changes in the store while it is offline (Sparkplug 3.0)."},
    {"publish", ValueType::kList, false, 1, 100000, "a channel label", "all",
     "`all` (every channel of every task) or a list of labels to publish."},
    {"deadband", ValueType::kLabelMap, false, 0, 0, nullptr, "0 (every change)",
     "Per label, the absolute change (in engineering units) below which no DATA is sent: "
     "`{ProcVal: 0.05}`. A change of quality is always sent."},
    {"writable", ValueType::kList, false, 1, 4096, "a set-point label", "(none: read-only)",
     "The set-points a DCMD may write, e.g. `[Setpoint]`. Writes go through the operator API "
     "with the operator's role (limits, retain, audit, as `rtplc set`); every other metric in a "
     "command is refused and logged."},
    {"aliases", ValueType::kBool, false, 0, 0, nullptr, "false",
     "Births give each metric an alias and DATA messages carry the alias instead of the name "
     "(smaller messages; every host handles both)."},
    {"store_and_forward", ValueType::kInteger, false, 0, 10000000, nullptr, "10000",
     "Changes kept while the broker or the primary host is away, replayed after the births "
     "with is_historical; the oldest are dropped (and counted) beyond this."},
    {"replay_rate", ValueType::kInteger, false, 1, 1000000, nullptr, "2000",
     "Stored changes replayed per second after a reconnect."},
    {"max_command", ValueType::kInteger, false, 64, 16777216, nullptr, "65536",
     "A command payload larger than this many bytes is refused without being decoded."},
};

const SectionSpec kSection{
    "sparkplug", "a sparkplug driver", "`kind: sparkplug`",
    "A Sparkplug B 3.0 edge node on an MQTT broker, for SCADA, historians and other plants' "
    "controllers: NBIRTH/NDEATH for the box, a device per task with DBIRTH/DDATA/DDEATH, "
    "values by exception with each value's quality as the `Quality` property (Ignition's "
    "codes), set-point writes by DCMD through the operator API, a primary host's STATE and a "
    "bounded store while nobody listens. Encoding and network I/O run on the driver's own "
    "thread below the task band; the tasks never wait for it. See docs/sparkplug.md.",
    kKeys};

SourcePos pos_or(const YAML::Node& n, SourcePos fallback) {
  const SourcePos p = YamlReader::pos(n);
  return p.line ? p : fallback;
}


void id_field(YamlReader& r, const Fields& f, const char* key, std::string& out) {
  const Field* x = f.get(key);
  if (!x) return;
  auto v = r.text(*x);
  if (!v) return;
  if (!valid_id(*v)) {
    r.error(*x, fmt::format("'{}' is a Sparkplug id: no '/', '+' or '#', at most 64 characters, got '{}'", key, *v));
    return;
  }
  out = *v;
}

void label_list(YamlReader& r, const Field& f, std::vector<std::string>& out, std::vector<SourcePos>& pos) {
  auto items = r.list(f);
  if (!items) return;
  for (const YAML::Node& n : *items) {
    const SourcePos at = pos_or(n, f.pos);
    if (!n.IsScalar() || n.Scalar().empty() || n.Scalar().size() >= 32) {
      r.error(at, "a channel label (1..31 characters), got " + YamlReader::describe_node(n));
      continue;
    }
    if (std::find(out.begin(), out.end(), n.Scalar()) != out.end()) {
      r.error(at, "\"" + n.Scalar() + "\" is listed twice");
      continue;
    }
    out.push_back(n.Scalar());
    pos.push_back(at);
  }
}

void parse(YamlReader& r, const Fields& f, DriverConfig& out) {
  SparkplugSettings s;
  s.pos = out.pos;
  if (const Field* b = f.get("broker")) {
    if (auto v = r.text(*b)) {
      std::string why;
      if (!parse_broker(*v, s, why)) r.error(*b, "'broker' " + why + " (e.g. 127.0.0.1:1883 or mqtts://broker:8883)");
    }
  }
  for (auto [key, dst] : {std::pair{"ca", &s.ca_file}, {"cert", &s.cert_file}, {"key", &s.key_file}}) {
    if (const Field* x = f.get(key)) {
      if (!s.tls) r.error(*x, fmt::format("'{}' applies to a TLS broker (mqtts://...)", key));
      if (auto v = r.path(*x)) *dst = *v;
    }
  }
  if (f.get("cert") && !f.get("key")) r.error(*f.get("cert"), "'cert' needs its 'key'");
  if (f.get("key") && !f.get("cert")) r.error(*f.get("key"), "'key' needs its 'cert'");
  if (const Field* x = f.get("username")) {
    if (auto v = r.text(*x)) s.username = *v;
  }
  if (const Field* x = f.get("password")) {
    if (!f.get("username")) r.error(*x, "'password' needs a 'username'");
    if (auto v = r.text(*x)) s.password = *v;
  }
  if (const Field* x = f.get("keepalive")) {
    if (auto v = r.duration(*x)) s.keepalive_s = *v;
  }
  if (const Field* x = f.get("mqtt")) {
    if (auto v = r.choice(*x)) s.mqtt5 = *v == "5";
  }
  id_field(r, f, "group", s.group);
  id_field(r, f, "node", s.node);
  id_field(r, f, "primary_host", s.primary_host);
  if (const Field* x = f.get("publish")) {
    if (x->value.IsScalar() && x->value.Scalar() == "all") {
      s.publish_all = true;
    } else {
      s.publish_all = false;
      label_list(r, *x, s.publish, s.publish_pos);
    }
  }
  if (const Field* x = f.get("deadband")) {
    if (!x->value.IsMap()) {
      r.error(*x, "'deadband' is a map label -> change, e.g. {ProcVal: 0.05}, got " + YamlReader::describe_node(x->value));
    } else {
      for (const auto& kv : x->value) {
        const SourcePos at = pos_or(kv.first, x->pos);
        const std::string label = kv.first.IsScalar() ? kv.first.Scalar() : "";
        auto v = r.real(kv.second, at, "a deadband");
        if (!v) continue;
        if (*v < 0) {
          r.error(at, fmt::format("the deadband of \"{}\" is a change >= 0, got {}", label, *v));
          continue;
        }
        s.deadband[label] = *v;
        s.deadband_pos[label] = at;
      }
    }
  }
  if (const Field* x = f.get("writable")) label_list(r, *x, s.writable, s.writable_pos);
  if (const Field* x = f.get("aliases")) {
    if (auto v = r.boolean(*x)) s.aliases = *v;
  }
  if (const Field* x = f.get("store_and_forward")) {
    if (auto v = r.integer(*x)) s.store_and_forward = static_cast<uint32_t>(*v);
  }
  if (const Field* x = f.get("replay_rate")) {
    if (auto v = r.integer(*x)) s.replay_rate = static_cast<uint32_t>(*v);
  }
  if (const Field* x = f.get("max_command")) {
    if (auto v = r.integer(*x)) s.max_command_bytes = static_cast<uint32_t>(*v);
  }
  out.settings = std::move(s);
}

// The link reads the image like `rtplc monitor` and sets set-points through
// the runtime: no region of its own, one link row (the broker session).
DriverClaims claims(const DriverConfig&) {
  DriverClaims c;
  c.links = 1;
  return c;
}

std::string doc() {
  return "Example: this box as edge node `rtplc-01` of group `Plant1`, waiting for the SCADA "
         "host `scada`, letting it write one set-point:\n\n```yaml\ndrivers:\n  - kind: sparkplug\n"
         "    name: plant\n    broker: 127.0.0.1:1883\n    group: Plant1\n    node: rtplc-01\n"
         "    primary_host: scada\n    deadband: {ProcVal: 0.01}\n    writable: [Setpoint]\n```\n\n"
         "See docs/sparkplug.md for the topics, the metric mapping and the qualities.\n";
}

}  // namespace

bool parse_broker(const std::string& text, SparkplugSettings& s, std::string& why) {
  std::string rest = text;
  if (rest.rfind("mqtts://", 0) == 0) {
    s.tls = true;
    s.port = 8883;
    rest = rest.substr(8);
  } else if (rest.rfind("mqtt://", 0) == 0) {
    rest = rest.substr(7);
  } else if (rest.find("://") != std::string::npos) {
    why = "the broker's scheme is mqtt:// or mqtts://";
    return false;
  }
  if (!rest.empty() && rest.back() == '/') rest.pop_back();
  const size_t colon = rest.rfind(':');
  std::string host = rest;
  if (colon != std::string::npos && rest.find(']') == std::string::npos) {
    host = rest.substr(0, colon);
    const std::string p = rest.substr(colon + 1);
    unsigned port = 0;
    const auto [end, ec] = std::from_chars(p.data(), p.data() + p.size(), port);
    if (p.empty() || ec != std::errc() || end != p.data() + p.size() || port == 0 || port > 65535) {
      why = "the port is a number 1..65535, got '" + p + "'";
      return false;
    }
    s.port = static_cast<uint16_t>(port);
  }
  if (host.empty() || host.find_first_of(" /") != std::string::npos) {
    why = "no host name";
    return false;
  }
  s.host = host;
  return true;
}

std::string SparkplugSettings::broker_text() const {
  return fmt::format("{}{}:{}", tls ? "mqtts://" : "", host, port);
}

bool valid_id(const std::string& id) {
  return !id.empty() && id.size() <= 64 && id.find_first_of("/+#") == std::string::npos &&
         std::none_of(id.begin(), id.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; });
}

const SparkplugSettings& settings_of(const DriverConfig& d) { return settings_as<SparkplugSettings>(d); }

const DriverKind kConfigKind{
    "sparkplug", "a Sparkplug B edge node on an MQTT broker, for SCADA and historians",
    &kSection, {}, &parse, &claims, &doc,
};

}  // namespace rtplc::sparkplug
