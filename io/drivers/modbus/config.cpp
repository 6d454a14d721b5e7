// The `modbus` driver kind of the configuration (issue 9, item 1): slaves over
// TCP or RTU with their poll period, timeout, retries and batching caps, and
// the maps from the PLC blocks' X/Y/M/R channels to Modbus items. Every value
// is checked here with a position, so a config that loads never fails later.
#include <arpa/inet.h>

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <string>

#include "io/drivers/modbus/config.h"
#include "io/drivers/modbus/planner.h"

#include "blocks/image.h"
#include "config/map_entries.h"
#include "config/yaml_reader.h"

namespace rtplc::modbus {
using namespace config;
namespace {

const KeySpec kModbusKeys[] = {
    {"slaves", ValueType::kList, true, 1, 1024, "modbus-slave", "",
     "The slaves this driver polls: TCP slaves each on their own connection, RTU units "
     "naming one `device` share its line."},
    {"read", ValueType::kList, false, 0, 65536, "modbus-map", "no reads",
     "Items read into `prx`/`pry`/`prm`/`prr` channels (`in/PLC<device>/pN.dN.cN`)."},
    {"write", ValueType::kList, false, 0, 65536, "modbus-map", "no writes",
     "Items written from `pwy`/`pwm`/`pwr` channels (`out/PLC<device>/pN.dN.cN`)."},
};

const KeySpec kSlaveKeys[] = {
    {"name", ValueType::kName, true, 0, 0, nullptr, "", "The slave's name in maps, status and logs."},
    {"address", ValueType::kText, false, 0, 0, "numeric IPv4", "none: RTU",
     "Modbus TCP: the slave's IPv4 address (give `address` or `device`)."},
    {"port", ValueType::kInteger, false, 1, 65535, nullptr, "502", "Modbus TCP port."},
    {"device", ValueType::kText, false, 0, 0, "serial device", "none: TCP",
     "Modbus RTU: the serial device (/dev/ttyUSB0); slaves naming the same device share the line."},
    {"baud", ValueType::kInteger, false, 300, 4000000, nullptr, "19200", "RTU: bits per second."},
    {"parity", ValueType::kChoice, false, 0, 0, "N|E|O", "E", "RTU: none, even or odd."},
    {"data_bits", ValueType::kInteger, false, 5, 8, nullptr, "8", "RTU: data bits."},
    {"stop_bits", ValueType::kInteger, false, 1, 2, nullptr, "1", "RTU: stop bits."},
    {"unit", ValueType::kInteger, false, 0, 247, nullptr, "1", "The unit (slave) id."},
    {"poll", ValueType::kDuration, false, 0.001, 3600, nullptr, "100ms",
     "Every read item of this slave is read this often (unless its map says `poll`)."},
    {"timeout", ValueType::kDuration, false, 0.001, 60, nullptr, "500ms",
     "A request unanswered this long is a timeout."},
    {"retries", ValueType::kInteger, false, 0, 10, nullptr, "1",
     "Further attempts after a timeout before the poll fails (TCP: then reconnect)."},
    {"m_offset", ValueType::kInteger, false, 0, 65535, nullptr, "0",
     "M channels map to coil `address + m_offset`."},
    {"max_registers", ValueType::kInteger, false, 1, 125, nullptr, "125",
     "At most this many registers per read request (contiguous items are batched)."},
    {"max_bits", ValueType::kInteger, false, 1, 2000, nullptr, "2000",
     "At most this many coils or discrete inputs per read request."},
    {"plan", ValueType::kPath, false, 0, 0, nullptr, "unplanned",
     "RTU: the fieldbus plan the line runs on, an `rtplc fieldbus plan` input file (relative "
     "to this file) with `layout: modbus-rtu` at this `baud`; every slave on the device names "
     "the same one. Planned when the config loads; a design that cannot work refuses to start "
     "with the planner's reason. Reads then need `loop` or `class: nonrt`; writes are urgent "
     "(docs/fieldbus.md, \"Running a link on a plan\")."},
};

const KeySpec kMapKeys[] = {
    {"device", ValueType::kChoice, true, 0, 0, "X|Y|M|R", "",
     "The block's device letter: X discrete input, Y coil, M coil at `m_offset`, R register."},
    {"channel", ValueType::kChannel, true, 0, 0, nullptr, "",
     "The block's address pN.dN.cN (its p, d, c)."},
    {"slave", ValueType::kName, true, 0, 0, nullptr, "", "A name from `slaves`."},
    {"address", ValueType::kInteger, true, 0, 65535, nullptr, "", "The 0-based protocol address."},
    {"table", ValueType::kChoice, false, 0, 0, "hr|ir", "hr",
     "R reads only: holding registers or input registers."},
    {"type", ValueType::kChoice, false, 0, 0, "u16|i16|u32|i32|f32", "u16",
     "R only: the register's type; u32/i32/f32 take two registers."},
    {"word_order", ValueType::kChoice, false, 0, 0, "high_first|low_first", "high_first",
     "R two-register types: which word comes first."},
    {"scale", ValueType::kReal, false, 0, 0, nullptr, "1",
     "R only: engineering value = raw * scale + offset (writes apply the inverse)."},
    {"offset", ValueType::kReal, false, 0, 0, nullptr, "0", "See scale."},
    {"poll", ValueType::kDuration, false, 0.001, 3600, nullptr, "the slave's",
     "Reads only: this item's poll period (items with equal periods are batched together)."},
    {"mode", ValueType::kChoice, false, 0, 0, "on_change|every_cycle", "on_change",
     "Writes only: send when the task's value changes (and again after a failure or a "
     "reconnect), or every driver cycle."},
    {"loop", ValueType::kName, false, 0, 0, nullptr, "none",
     "Reads of a slave on a plan: the plan's loop whose windows the item is read in (items of "
     "one loop are batched as usual; no `poll` then)."},
    {"class", ValueType::kChoice, false, 0, 0, "periodic|urgent|nonrt", "periodic with `loop`, urgent for writes",
     "On a plan: `nonrt` reads (large ranges) are read every `poll`, cut into requests of at most "
     "L_n, in what the T_1 frames leave; writes are `urgent`: first in the frame they change in."},
};

const SectionSpec kModbusSection{
    "modbus", "a modbus driver", "`kind: modbus`",
    "The Modbus master, TCP and RTU. Each TCP slave has its own I/O thread (below the task "
    "band) with its own timeout, so a slave that is slow, silent or gone costs the others "
    "nothing; RTU units on one line are served in turn, and a unit that stopped answering is "
    "polled less often until it answers. Contiguous items of one slave, table and poll period "
    "are read with as few requests as the caps allow. `period` is how often the driver "
    "exchanges values with the process image (and the longest a write waits before it is "
    "sent). A slave that times out marks exactly its channels bad, keeping their last "
    "values; its statistics are a link row in `rtplc status` and `rtplc monitor`.",
    kModbusKeys};
const SectionSpec kSlaveSection{"modbus-slave", "a Modbus slave", "`slaves:` entries of a modbus driver", "",
                                kSlaveKeys};
const SectionSpec kMapSection{"modbus-map", "a channel map", "`read:` and `write:` entries of a modbus driver",
                              "", kMapKeys};
const SectionSpec* const kSubsections[] = {&kSlaveSection, &kMapSection};

// `plans` holds the plan files the driver's slaves named so far: the slaves of
// one line all name its plan, which is read and planned once for them all.
void parse_slave(YamlReader& r, const YAML::Node& node, SourcePos where, fieldbus::LinkPlanCache& plans,
                 ModbusSettings& out) {
  SlaveConfig sc;
  sc.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  sc.name_pos = sc.address_pos = sc.pos;
  Fields f = r.fields(node, sc.pos, kSlaveSection.noun, {kSlaveSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  if (const Field* n = f.get("name")) {
    sc.name_pos = n->pos;
    if (auto v = r.name(*n)) sc.name = *v;
    else ok = false;
  } else {
    ok = false;
  }
  const Field* addr = f.get("address");
  const Field* dev = f.get("device");
  if ((addr != nullptr) == (dev != nullptr)) {
    r.error(addr ? addr->pos : dev ? dev->pos : sc.pos,
            "a Modbus slave needs exactly one of 'address' (TCP) or 'device' (RTU)");
    ok = false;
  }
  if (addr) {
    sc.address_pos = addr->pos;
    if (auto v = r.text(*addr)) {
      in_addr probe{};
      if (inet_pton(AF_INET, v->c_str(), &probe) == 1) {
        sc.address = *v;
      } else {
        r.error(*addr, "'address' must be a numeric IPv4 address (the driver never waits on DNS), got '" + *v + "'");
        ok = false;
      }
    } else {
      ok = false;
    }
  }
  if (dev) {
    sc.address_pos = dev->pos;
    if (auto v = r.text(*dev)) sc.device = *v;
    else ok = false;
  }
  auto int_key = [&](const char* key, auto& dst) {
    if (const Field* k = f.get(key)) {
      if (auto v = r.integer(*k)) dst = static_cast<std::remove_reference_t<decltype(dst)>>(*v);
      else ok = false;
    }
  };
  int_key("port", sc.port);
  int_key("baud", sc.baud);
  int_key("data_bits", sc.data_bits);
  int_key("stop_bits", sc.stop_bits);
  int_key("unit", sc.unit);
  int_key("retries", sc.retries);
  int_key("m_offset", sc.m_offset);
  int_key("max_registers", sc.max_registers);
  int_key("max_bits", sc.max_bits);
  if (const Field* p = f.get("parity")) {
    if (auto v = r.choice(*p)) sc.parity = (*v)[0];
    else ok = false;
  }
  for (const char* key : {"port"}) {
    if (f.get(key) && !sc.device.empty()) {
      r.error(*f.get(key), fmt::format("'{}' applies to TCP slaves only", key));
      ok = false;
    }
  }
  for (const char* key : {"baud", "parity", "data_bits", "stop_bits"}) {
    if (f.get(key) && sc.device.empty() && dev == nullptr) {
      r.error(*f.get(key), fmt::format("'{}' applies to RTU slaves (with 'device') only", key));
      ok = false;
    }
  }
  if (const Field* p = f.get("poll")) {
    if (auto v = r.duration(*p)) sc.poll_s = *v;
    else ok = false;
  }
  if (const Field* p = f.get("timeout")) {
    if (auto v = r.duration(*p)) sc.timeout_s = *v;
    else ok = false;
  }
  if (const Field* p = f.get("plan")) {
    sc.plan_pos = p->pos;
    if (!dev) {
      r.error(*p, "'plan' applies to RTU slaves (with 'device') only: a TCP slave has a line of its own");
      ok = false;
    } else if (auto path = r.path(*p)) {
      sc.plan_file = *path;
      const fieldbus::LinkPlanCache::Loaded& lp = plans.get(*path);
      if (!lp) {
        r.error(*p, lp.error());
        ok = false;
      } else if (!(*lp)->design.timing || (*lp)->design.timing->layout != fieldbus::FrameLayout::kModbusRtu) {
        r.error(*p, "the plan " + *path + " gives no Modbus RTU layout: an RTU line's plan needs 'bit_rate' and "
                    "'layout: modbus-rtu' in its link, so the requests' wire times are known");
        ok = false;
      } else if (std::llround((*lp)->design.timing->bit_rate) != static_cast<long long>(sc.baud)) {
        r.error(*p, fmt::format("the plan {} is for {} bit/s, the line runs at {} baud", *path,
                                std::llround((*lp)->design.timing->bit_rate), sc.baud));
        ok = false;
      } else {
        sc.plan = *lp;
      }
    } else {
      ok = false;
    }
  }
  if (ok) out.slaves.push_back(std::move(sc));
}

void parse_map(YamlReader& r, const YAML::Node& node, SourcePos where, bool write, std::vector<ChannelMap>& out) {
  ChannelMap m;
  m.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  m.channel_pos = m.slave_pos = m.pos;
  Fields f = r.fields(node, m.pos, kMapSection.noun, {kMapSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  if (const Field* d = f.get("device")) {
    if (auto v = r.choice(*d)) m.device = (*v)[0];
    else ok = false;
  }
  if (write && m.device == 'X' && f.get("device")) {
    r.error(*f.get("device"), "X maps to discrete inputs, which a master cannot write (use Y, M or R)");
    ok = false;
  }
  ok &= parse_channel_field(r, f, "channel", false, m.addr, m.channel, &m.channel_pos);
  if (const Field* s = f.get("slave")) {
    m.slave_pos = s->pos;
    if (auto v = r.name(*s)) m.slave = *v;
    else ok = false;
  }
  int64_t address = 0;
  if (const Field* a = f.get("address")) {
    if (auto v = r.integer(*a)) address = *v;
    else ok = false;
  }
  const bool reg = m.device == 'R';
  m.item.table = m.device == 'X' ? Table::kDiscreteInput : reg ? Table::kHoldingRegister : Table::kCoil;
  m.item.type = reg ? ItemType::kU16 : ItemType::kBit;
  m.item.address = static_cast<uint16_t>(address);
  for (const char* key : {"table", "type", "word_order", "scale", "offset"}) {
    if (f.get(key) && !reg) {
      r.error(*f.get(key), fmt::format("'{}' applies to R (register) maps only", key));
      ok = false;
    }
  }
  if (const Field* t = f.get("table"); t && reg) {
    if (auto v = r.choice(*t)) {
      if (*v == "ir") {
        if (write) {
          r.error(*t, "input registers are read-only: a write map writes holding registers");
          ok = false;
        }
        m.item.table = Table::kInputRegister;
      }
    } else {
      ok = false;
    }
  }
  if (const Field* t = f.get("type"); t && reg) {
    if (auto v = r.choice(*t)) {
      auto a = parse_address(fmt::format("hr:0:{}", *v));
      if (a) m.item.type = a->type;
    } else {
      ok = false;
    }
  }
  if (const Field* w = f.get("word_order"); w && reg) {
    if (auto v = r.choice(*w)) {
      if (width(m.item) != 2) {
        r.error(*w, "'word_order' applies to two-register types (u32, i32, f32) only");
        ok = false;
      }
      m.item.swapped = *v == "low_first";
    } else {
      ok = false;
    }
  }
  if (ok && address + width(m.item) > 65536) {
    r.error(*f.get("address"), "a two-register value needs address + 1 <= 65535");
    ok = false;
  }
  if (reg) ok &= parse_scaling(r, f, m.pos, m.scale, m.offset);  // bits: refused above
  if (const Field* p = f.get("poll")) {
    if (write) {
      r.error(*p, "'poll' applies to read maps only");
      ok = false;
    } else if (auto v = r.duration(*p)) {
      m.poll_s = *v;
    } else {
      ok = false;
    }
  }
  ok &= parse_write_mode(r, f, write, m.mode);
  if (const Field* l = f.get("loop")) {
    if (write) {
      r.error(*l, "a write on a plan is urgent (sent when it changes, first in its frame), not in a loop");
      ok = false;
    } else if (auto v = r.name(*l)) {
      m.loop = *v;
      m.traffic = ChannelMap::Traffic::kPeriodic;
    } else {
      ok = false;
    }
  }
  if (const Field* c = f.get("class")) {
    if (auto v = r.choice(*c)) {
      const bool loop = f.get("loop") != nullptr;
      if (write && *v != "urgent") {
        r.error(*c, "a write on a plan is urgent: 'class: urgent' (or no class)");
        ok = false;
      } else if (!write && *v == "urgent") {
        r.error(*c, "a read is periodic (with 'loop') or 'nonrt'; only writes are urgent");
        ok = false;
      } else if (*v == "periodic" && !loop) {
        r.error(*c, "a periodic read needs 'loop': the plan's loop whose windows it is read in");
        ok = false;
      } else if (*v == "nonrt" && loop) {
        r.error(*c, "a non-RT read is not in a loop's windows: drop 'loop' or the class");
        ok = false;
      } else if (*v == "nonrt") {
        m.traffic = ChannelMap::Traffic::kNonRt;
      } else if (*v == "urgent") {
        m.traffic = ChannelMap::Traffic::kUrgent;
      }
    } else {
      ok = false;
    }
  }
  if (f.get("poll") && m.traffic == ChannelMap::Traffic::kPeriodic) {
    r.error(*f.get("poll"), "an item of loop '" + m.loop + "' is read at the loop's period from the plan; drop 'poll'");
    ok = false;
  }
  if (ok) out.push_back(std::move(m));
}

// The maps of slaves on a plan: every read in a loop the plan has or non-RT,
// every write urgent; a loop's requests no longer than L_p, a write's no
// longer than L_c, no more urgent writes per line than the plan's N_c.
void check_planned_maps(YamlReader& r, ModbusSettings& s, const std::map<std::string, const SlaveConfig*>& names) {
  std::map<std::string, int> urgent_per_line;
  for (auto* maps : {&s.reads, &s.writes}) {
    const bool write = maps == &s.writes;
    for (ChannelMap& m : *maps) {
      auto it = names.find(m.slave);
      if (it == names.end()) continue;
      const SlaveConfig& sc = *it->second;
      if (!sc.plan) {
        if (m.traffic != ChannelMap::Traffic::kUnplanned) {
          r.error(m.pos, "'loop' or 'class' needs the slave's 'plan' (slave '" + sc.name + "' has none)");
        }
        continue;
      }
      const fieldbus::LinkPlan& lp = *sc.plan;
      const fieldbus::LinkTiming& timing = *lp.design.timing;
      const int bytes = m.item.type == ItemType::kBit ? 1 : 2 * width(m.item);
      if (write) {
        m.traffic = ChannelMap::Traffic::kUrgent;
        if (++urgent_per_line[sc.device] == lp.design.rt_queues + 1) {
          r.error(m.pos, fmt::format("more urgent writes on {} than the plan's {} real-time queues (N_c): each "
                                     "write is one",
                                     sc.device, lp.design.rt_queues));
        }
        if (timing.packet(bytes) > lp.design.rt_packet) {
          r.error(m.pos, fmt::format("this write's {} data bytes take {} on the line, longer than the plan's "
                                     "real-time packet L_c = {}",
                                     bytes, fieldbus::format_time(timing.packet(bytes)),
                                     fieldbus::format_time(lp.design.rt_packet)));
        }
        continue;
      }
      if (m.traffic == ChannelMap::Traffic::kUnplanned) {
        r.error(m.pos, fmt::format("read {} {} of slave '{}' is not in the plan: give it 'loop: NAME' (one of {}) "
                                   "or 'class: nonrt'",
                                   m.device, m.channel, sc.name, lp.loop_names()));
      } else if (m.traffic == ChannelMap::Traffic::kPeriodic && !lp.loop(m.loop)) {
        r.error(m.pos, fmt::format("the plan has no loop '{}' (its loops: {})", m.loop, lp.loop_names()));
      } else if (m.traffic == ChannelMap::Traffic::kNonRt && timing.packet(bytes) > lp.plan.ln_max) {
        r.error(m.pos, fmt::format("L_n max = {} is shorter than this item's {} bytes on the line ({})",
                                   fieldbus::format_time(lp.plan.ln_max), bytes,
                                   fieldbus::format_time(timing.packet(bytes))));
      }
    }
  }
  // A loop's items of one slave are read in as few requests as the caps allow:
  // each request's data must fit L_p.
  for (const SlaveConfig& sc : s.slaves) {
    if (!sc.plan) continue;
    std::map<std::string, std::vector<PlannedItem>> by_loop;
    std::map<std::string, const ChannelMap*> first;
    for (uint32_t i = 0; i < s.reads.size(); ++i) {
      const ChannelMap& m = s.reads[i];
      if (m.slave != sc.name || m.traffic != ChannelMap::Traffic::kPeriodic) continue;
      by_loop[m.loop].push_back({m.item, 1, i});
      first.emplace(m.loop, &m);
    }
    const fieldbus::LinkPlan& lp = *sc.plan;
    for (const auto& [loop, items] : by_loop) {
      for (const Block& b : plan_blocks(items, sc.max_registers, sc.max_bits)) {
        const bool bits = b.table == Table::kCoil || b.table == Table::kDiscreteInput;
        const int bytes = bits ? (b.count + 7) / 8 : 2 * b.count;
        const fieldbus::Nanos wire = lp.design.timing->packet(bytes);
        if (wire > lp.design.periodic_packet) {
          r.error(first[loop]->pos,
                  fmt::format("loop '{}' of slave '{}' reads {} data bytes in one request ({} on the line), longer "
                              "than the plan's periodic packet L_p = {}; lower 'max_registers' or split the loop",
                              loop, sc.name, bytes, fieldbus::format_time(wire),
                              fieldbus::format_time(lp.design.periodic_packet)));
        }
      }
    }
  }
}

void parse_modbus(YamlReader& r, const Fields& f, DriverConfig& out) {
  ModbusSettings s;
  if (const Field* slaves = f.get("slaves")) {
    if (auto items = r.list(*slaves)) {
      fieldbus::LinkPlanCache plans;
      for (const YAML::Node& n : *items) parse_slave(r, n, slaves->pos, plans, s);
    }
  }
  for_each_map_entry(r, f, [&](const YAML::Node& n, SourcePos at, bool write) {
    parse_map(r, n, at, write, write ? s.writes : s.reads);
  });
  std::map<std::string, const SlaveConfig*> names;
  std::map<std::string, const SlaveConfig*> lines;  // RTU device -> first slave on it
  for (const SlaveConfig& sc : s.slaves) {
    auto [it, fresh] = names.emplace(sc.name, &sc);
    if (!fresh) {
      r.error(sc.name_pos, used_twice("slave", sc.name, it->second->name_pos.line));
    }
    if (!sc.rtu()) continue;
    auto [line, first] = lines.emplace(sc.device, &sc);
    if (first) continue;
    const SlaveConfig& o = *line->second;
    if (o.baud != sc.baud || o.parity != sc.parity || o.data_bits != sc.data_bits || o.stop_bits != sc.stop_bits) {
      r.error(sc.address_pos, fmt::format("slave '{}' is on {} with other line settings than '{}' (line {})",
                                          sc.name, sc.device, o.name, o.pos.line));
    }
    if (o.plan_file != sc.plan_file) {
      r.error(sc.plan_pos.line ? sc.plan_pos : sc.address_pos,
              fmt::format("slave '{}' is on {} with another plan than '{}' (line {}): one line runs on one plan",
                          sc.name, sc.device, o.name, o.pos.line));
    }
    if (o.unit == sc.unit) {
      r.error(sc.address_pos, fmt::format("slave '{}' has unit {} on {}, as '{}' (line {}) has", sc.name,
                                          sc.unit, sc.device, o.name, o.pos.line));
    }
  }
  for (auto* maps : {&s.reads, &s.writes}) {
    FirstSeen seen;
    for (ChannelMap& m : *maps) {
      auto it = names.find(m.slave);
      if (it == names.end()) {
        r.error(m.slave_pos, "no slave named '" + m.slave + "' in this driver's slaves");
        continue;
      }
      if (m.device == 'M') {
        const uint32_t coil = uint32_t{m.item.address} + it->second->m_offset;
        if (coil > 65535) {
          r.error(m.pos, fmt::format("M address {} + m_offset {} is beyond coil 65535", m.item.address,
                                     it->second->m_offset));
        }
        m.item.address = static_cast<uint16_t>(coil);
      }
      if (m.traffic == ChannelMap::Traffic::kNonRt && m.poll_s <= 0) m.poll_s = it->second->poll_s;
      refuse_mapped_twice(r, seen, std::string(1, m.device) + "/" + m.channel,
                          std::string(1, m.device) + " " + m.channel, m.channel_pos);
    }
  }
  check_planned_maps(r, s, names);
  out.settings = std::move(s);
}

std::string modbus_doc() {
  return "Example: a register pair as a float into `prr(p1, d0, c0, ...)`, a coil from "
         "`pwy(..., p1, d0, c1, ...)`:\n\n```yaml\ndrivers:\n  - kind: modbus\n    name: field\n"
         "    slaves:\n      - {name: pump, address: 10.0.0.20, unit: 1, poll: 50ms, timeout: 200ms}\n"
         "      - {name: meter, device: /dev/ttyUSB0, baud: 19200, parity: E, unit: 7}\n"
         "    read:\n      - {device: R, channel: p1.d0.c0, slave: pump, address: 4, type: f32}\n"
         "      - {device: X, channel: p1.d0.c2, slave: meter, address: 3}\n"
         "    write:\n      - {device: Y, channel: p1.d0.c1, slave: pump, address: 21}\n```\n\n"
         "See docs/modbus.md for the commissioning commands and the fake slave.\n";
}

// Each read map provides a channel (region index = map index); each write map
// consumes a task output; each slave is one link row.
DriverClaims modbus_claims(const DriverConfig& d) {
  const ModbusSettings& s = settings_of(d);
  DriverClaims c;
  claim_maps(c, s.reads, s.writes, [&](const ChannelMap& m, bool write) {
    ChannelClaim cl{write ? write_key(m) : read_key(m), fmt::format("{}.{}.{}", d.name, m.device, m.channel),
                    m.channel_pos};
    // Vouched for three polls: a slave frozen mid-answer, or a line too busy
    // to poll it, turns its values stale for every consumer (io::judge_quality).
    for (const SlaveConfig& sl : s.slaves) {
      if (sl.name != m.slave) continue;
      const double poll = m.poll_s > 0 ? m.poll_s : sl.poll_s;
      cl.max_age_ns = static_cast<int64_t>(3 * poll * 1e9);
    }
    return cl;
  });
  c.links = static_cast<uint32_t>(s.slaves.size());
  return c;
}

}  // namespace

std::string SlaveConfig::peer() const {
  if (rtu()) return fmt::format("{} unit {}", device, unit);
  return fmt::format("{}:{} unit {}", address, port, unit);
}

const ModbusSettings& settings_of(const DriverConfig& d) { return settings_as<ModbusSettings>(d); }

std::string read_key(const ChannelMap& m) {
  return channel_key(BindingDir::kInput, IoGroup::kPlc, m.device, m.addr.p, m.addr.d, m.addr.c);
}

std::string write_key(const ChannelMap& m) {
  return channel_key(BindingDir::kOutput, IoGroup::kPlc, m.device, m.addr.p, m.addr.d, m.addr.c);
}

const DriverKind kConfigKind{
    "modbus",         "Modbus TCP and RTU slaves, for prx/pry/prm/prr/pwy/pwm/pwr",
    &kModbusSection,  kSubsections,
    &parse_modbus,    &modbus_claims,
    &modbus_doc,
};

}  // namespace rtplc::modbus
