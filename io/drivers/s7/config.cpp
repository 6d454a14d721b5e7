// The `s7` driver kind of the configuration (spec s7-client.md; issue "S7
// multi-PLC client", item 5): the PLCs — address, rack/slot or TSAPs, poll
// period — and the maps from era/erd/ewa/ewd channels to S7 items. Item
// addresses are checked with the very parser `rtplc s7 read` uses, so a config
// that loads never fails later on an item.
#include <arpa/inet.h>

#include <set>
#include <string>

#include "io/drivers/s7/config.h"

#include "blocks/image.h"
#include "config/map_entries.h"
#include "config/yaml_reader.h"
#include "io/drivers/s7/address.h"

namespace rtplc::s7 {
using namespace config;
namespace {

const KeySpec kS7Keys[] = {
    {"plcs", ValueType::kList, true, 1, 1024, "s7-plc", "",
     "The PLCs this driver talks to, all from one event loop."},
    {"read", ValueType::kList, false, 0, 65536, "s7-map", "no reads",
     "Items read into `era`/`erd` channels (`in/ETH/pN.dN.cN`)."},
    {"write", ValueType::kList, false, 0, 65536, "s7-map", "no writes",
     "Items written from `ewa`/`ewd` channels (`out/ETH/pN.dN.cN`)."},
};

const KeySpec kPlcKeys[] = {
    {"name", ValueType::kName, true, 0, 0, nullptr, "", "The PLC's name in maps, status and logs."},
    {"address", ValueType::kText, true, 0, 0, "numeric IPv4", "", "The PLC's IPv4 address."},
    {"port", ValueType::kInteger, false, 1, 65535, nullptr, "102", "ISO-on-TCP port."},
    {"rack", ValueType::kInteger, false, 0, 7, nullptr, "0", "Rack of the CPU (called TSAP)."},
    {"slot", ValueType::kInteger, false, 0, 31, nullptr, "1",
     "Slot of the CPU (S7-300: 2, S7-1200/1500: 1)."},
    {"connection", ValueType::kChoice, false, 0, 0, "pg|op|basic", "pg",
     "Connection type in the called TSAP."},
    {"local_tsap", ValueType::kText, false, 0, 0, "0x0000..0xFFFF", "0x0100",
     "Calling TSAP, for S7-200/LOGO (e.g. 0x1000)."},
    {"remote_tsap", ValueType::kText, false, 0, 0, "0x0000..0xFFFF", "from rack/slot",
     "Called TSAP, for S7-200/LOGO (e.g. 0x2000); replaces rack/slot."},
    {"poll", ValueType::kDuration, false, 0.001, 3600, nullptr, "100ms",
     "Every read item of this PLC is read this often."},
    {"reply_timeout", ValueType::kDuration, false, 0.001, 60, nullptr, "1s",
     "A request unanswered this long drops the connection (then reconnects with backoff)."},
    {"pdu", ValueType::kInteger, false, 240, 960, nullptr, "480", "PDU size asked for."},
    {"amq", ValueType::kInteger, false, 1, 32, nullptr, "8", "Parallel jobs asked for."},
};

const KeySpec kMapKeys[] = {
    {"channel", ValueType::kChannel, true, 0, 0, nullptr, "",
     "The block's address pN.dN.cN (the era/erd/ewa/ewd block's p, d, c)."},
    {"plc", ValueType::kName, true, 0, 0, nullptr, "", "A name from `plcs`."},
    {"item", ValueType::kText, true, 0, 0, "S7 address", "",
     "The S7 item, as `rtplc s7 read` takes it: DB1.DBD8:REAL, DB1.DBW4, MW2, M0.1, IB0, Q0.1, ..."},
    {"scale", ValueType::kReal, false, 0, 0, nullptr, "1",
     "Engineering value = raw * scale + offset (writes apply the inverse)."},
    {"offset", ValueType::kReal, false, 0, 0, nullptr, "0", "See scale."},
    {"mode", ValueType::kChoice, false, 0, 0, "on_change|every_cycle", "on_change",
     "Writes only: send when the task's value changes (and again after a failure), or every "
     "driver cycle."},
};

const SectionSpec kS7Section{
    "s7", "an s7 driver", "`kind: s7`",
    "The S7 multi-PLC client: one event loop for every PLC (hundreds are fine), each PLC "
    "polled within about one network round trip, a dead or slow PLC costing the others "
    "nothing. `period` is how often the driver exchanges values with the process image; "
    "`priority` applies to that exchange (the network loop runs below the task band). A read "
    "value carries the PLC's quality (good, stale after a few missed polls, bad when the PLC "
    "is gone — the last value stays); every write is acknowledged, failed (then sent again) "
    "or pending, and counted per PLC in `rtplc status` and `rtplc monitor`.",
    kS7Keys};
const SectionSpec kPlcSection{"s7-plc", "a PLC", "`plcs:` entries of an s7 driver", "", kPlcKeys};
const SectionSpec kMapSection{"s7-map", "a channel map", "`read:` and `write:` entries of an s7 driver",
                              "", kMapKeys};
const SectionSpec* const kS7Subsections[] = {&kPlcSection, &kMapSection};

std::optional<uint16_t> parse_tsap(YamlReader& r, const Field& f) {
  auto s = r.text(f);
  if (!s) return std::nullopt;
  const bool hex = s->size() > 2 && (*s)[0] == '0' && ((*s)[1] == 'x' || (*s)[1] == 'X');
  char* end = nullptr;
  const unsigned long v = std::strtoul(s->c_str() + (hex ? 2 : 0), &end, hex ? 16 : 10);
  if (*end != '\0' || v > 0xFFFF || s->size() == (hex ? 2u : 0u)) {
    r.error(f, "'" + std::string(f.spec->key) + "' must be a TSAP 0x0000..0xFFFF, got '" + *s + "'");
    return std::nullopt;
  }
  return static_cast<uint16_t>(v);
}

void parse_plc(YamlReader& r, const YAML::Node& node, SourcePos where, S7DriverSettings& out) {
  S7PlcConfig pc;
  pc.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  Fields f = r.fields(node, pc.pos, kPlcSection.noun, {kPlcSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  if (const Field* n = f.get("name")) {
    pc.name_pos = n->pos;
    if (auto v = r.name(*n)) pc.name = *v;
    else ok = false;
  } else {
    ok = false;
  }
  if (const Field* a = f.get("address")) {
    pc.address_pos = a->pos;
    if (auto v = r.text(*a)) {
      in_addr probe{};
      if (inet_pton(AF_INET, v->c_str(), &probe) == 1) {
        pc.address = *v;
      } else {
        r.error(*a, "'address' must be a numeric IPv4 address (the engine never waits on DNS), got '" +
                        *v + "'");
        ok = false;
      }
    } else {
      ok = false;
    }
  } else {
    ok = false;
  }
  auto int_key = [&](const char* key, auto& dst) {
    if (const Field* k = f.get(key)) {
      if (auto v = r.integer(*k)) dst = static_cast<std::remove_reference_t<decltype(dst)>>(*v);
      else ok = false;
    }
  };
  int_key("port", pc.port);
  int_key("rack", pc.rack);
  int_key("slot", pc.slot);
  int_key("pdu", pc.pdu);
  int_key("amq", pc.amq);
  if (const Field* c = f.get("connection")) {
    if (auto v = r.choice(*c)) pc.connection_type = *v == "pg" ? 1 : *v == "op" ? 2 : 3;
    else ok = false;
  }
  if (const Field* t = f.get("local_tsap")) {
    pc.local_tsap = parse_tsap(r, *t);
    ok = ok && pc.local_tsap.has_value();
  }
  if (const Field* t = f.get("remote_tsap")) {
    pc.remote_tsap = parse_tsap(r, *t);
    ok = ok && pc.remote_tsap.has_value();
  }
  if (const Field* p = f.get("poll")) {
    if (auto v = r.duration(*p)) pc.poll_s = *v;
    else ok = false;
  }
  if (const Field* p = f.get("reply_timeout")) {
    if (auto v = r.duration(*p)) pc.reply_timeout_s = *v;
    else ok = false;
  }
  if (ok) out.plcs.push_back(std::move(pc));
}

void parse_map(YamlReader& r, const YAML::Node& node, SourcePos where, bool write,
               std::vector<S7ChannelMap>& out) {
  S7ChannelMap m;
  m.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  m.channel_pos = m.plc_pos = m.item_pos = m.pos;
  Fields f = r.fields(node, m.pos, kMapSection.noun, {kMapSection.keys});
  if (!f.is_map()) return;
  bool ok = parse_channel_field(r, f, "channel", true, m.addr, m.channel, &m.channel_pos);
  if (const Field* p = f.get("plc")) {
    m.plc_pos = p->pos;
    if (auto v = r.name(*p)) m.plc = *v;
    else ok = false;
  } else {
    ok = false;
  }
  if (const Field* i = f.get("item")) {
    m.item_pos = i->pos;
    if (auto v = r.text(*i)) {
      auto addr = s7::parse_address(*v);
      if (addr) {
        m.item = *v;
      } else {
        r.error(*i, "bad S7 item '" + *v + "': " + addr.error());
        ok = false;
      }
    } else {
      ok = false;
    }
  } else {
    ok = false;
  }
  ok &= parse_scaling(r, f, m.pos, m.scale, m.offset);
  ok &= parse_write_mode(r, f, write, m.mode);
  if (ok) out.push_back(std::move(m));
}

void parse_s7(YamlReader& r, const Fields& f, DriverConfig& out) {
  S7DriverSettings s;
  if (const Field* plcs = f.get("plcs")) {
    if (auto items = r.list(*plcs)) {
      for (const YAML::Node& n : *items) parse_plc(r, n, plcs->pos, s);
    }
  }
  for_each_map_entry(r, f, [&](const YAML::Node& n, SourcePos at, bool write) {
    parse_map(r, n, at, write, write ? s.writes : s.reads);
  });
  // Names unique; every map names a PLC; a channel is mapped once per direction.
  FirstSeen names;
  for (const S7PlcConfig& p : s.plcs) {
    if (auto first = names.again(p.name, p.name_pos)) r.error(p.name_pos, used_twice("PLC", p.name, *first));
  }
  for (auto* maps : {&s.reads, &s.writes}) {
    FirstSeen seen;
    for (const S7ChannelMap& m : *maps) {
      if (!names.has(m.plc)) r.error(m.plc_pos, "no PLC named '" + m.plc + "' in this driver's plcs");
      refuse_mapped_twice(r, seen, m.channel, m.channel, m.channel_pos);
    }
  }
  out.settings = std::move(s);
}

std::string s7_doc() {
  return "Example: a furnace PLC's voltage into `era(p1, d0, c0, ...)`, a set current out of "
         "`ewa(..., p1, d0, c1, ...)`:\n\n```yaml\ndrivers:\n  - kind: s7\n    name: furnaces\n"
         "    period: 10ms\n    plcs:\n      - {name: f01, address: 10.0.0.11, rack: 0, slot: 2, poll: 100ms}\n"
         "    read:\n      - {channel: p1.d0.c0, plc: f01, item: DB10.DBD0:REAL}\n"
         "    write:\n      - {channel: p1.d0.c1, plc: f01, item: DB10.DBW4, scale: 0.1}\n```\n";
}

// Each read map provides an era/erd channel (region index = map index); each
// write map consumes an ewa/ewd output; each PLC is one link row.
DriverClaims s7_claims(const DriverConfig& d) {
  const S7DriverSettings& s = settings_of(d);
  DriverClaims c;
  claim_maps(c, s.reads, s.writes, [&](const S7ChannelMap& m, bool write) {
    ChannelClaim cl{write ? write_key(m) : read_key(m), d.name + "." + m.channel, m.channel_pos};
    // Vouched for three polls of its PLC (io::judge_quality).
    for (const S7PlcConfig& plc : s.plcs) {
      if (plc.name == m.plc) cl.max_age_ns = static_cast<int64_t>(3 * plc.poll_s * 1e9);
    }
    return cl;
  });
  c.links = static_cast<uint32_t>(s.plcs.size());
  return c;
}

}  // namespace

const S7DriverSettings& settings_of(const DriverConfig& d) { return settings_as<S7DriverSettings>(d); }

std::string read_key(const S7ChannelMap& m) {
  return channel_key(BindingDir::kInput, IoGroup::kEth, 0, m.addr.p, m.addr.d, m.addr.c);
}

std::string write_key(const S7ChannelMap& m) {
  return channel_key(BindingDir::kOutput, IoGroup::kEth, 0, m.addr.p, m.addr.d, m.addr.c);
}

const DriverKind kConfigKind{
    "s7",         "Siemens S7 PLCs over ISO-on-TCP, for era/erd/ewa/ewd",
    &kS7Section,  kS7Subsections,
    &parse_s7,    &s7_claims,
    &s7_doc,
};

}  // namespace rtplc::s7
