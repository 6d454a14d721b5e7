// What the entries of every driver's channel maps share (the `read:`/`write:`
// lists of the s7 and modbus kinds, the `expose:` list of modbus-server, and
// the next kinds'): a linear scaling between the peer's raw value and the
// engineering value, and for writes when to send. One parser each, so every
// kind says the same thing about the same key.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "config/values.h"

namespace YAML {
class Node;
}

namespace rtplc::config {

class YamlReader;
class Fields;

enum class WriteMode : uint8_t {
  kOnChange,    // sent when the task's value changes (and again after a failure or reconnect)
  kEveryCycle,  // sent every driver cycle
};

// `scale` and `offset` of one entry (engineering value = raw * scale + offset,
// the inverse on writes); a scale of 0 is refused at `entry` or at its key.
// Returns false (errors reported) when either is bad; leaves absent ones as they are.
bool parse_scaling(YamlReader& r, const Fields& f, SourcePos entry, double& scale, double& offset);

// `mode: on_change | every_cycle`, which only write entries take.
bool parse_write_mode(YamlReader& r, const Fields& f, bool write, WriteMode& mode);

// Calls `parse(entry, list_position, write)` for each entry of the `read:`
// list, then of the `write:` list, when the driver's map has them.
void for_each_map_entry(YamlReader& r, const Fields& f,
                        const std::function<void(const YAML::Node&, SourcePos, bool)>& parse);

// The `pN.dN.cN` address at `key` of an entry (`channel:`, a sim plant's
// `input:`): its parts into `addr`, its spelling into `text` and, when `pos`
// is given, the key's position into it. False when the value is bad (reported)
// or the key is absent and `required` (fields() reports the missing key).
bool parse_channel_field(YamlReader& r, const Fields& f, const char* key, bool required, ChannelAddress& addr,
                         std::string& text, SourcePos* pos = nullptr);

// Where each key of a list was first given, so that a second one can be
// refused with the first one's line.
class FirstSeen {
 public:
  // nullopt when `key` is new (it is remembered as given at `at`), else the
  // line it was first given on.
  std::optional<uint32_t> again(const std::string& key, SourcePos at);
  bool has(const std::string& key) const { return first_.count(key) != 0; }

 private:
  std::map<std::string, SourcePos> first_;
};

// Reports "channel LABEL is mapped twice (first at line N)" at `at` when
// `key` was mapped before in this direction.
void refuse_mapped_twice(YamlReader& r, FirstSeen& seen, const std::string& key, const std::string& label,
                         SourcePos at);

// "NOUN name 'NAME' is used twice (first at line N)", for a list whose
// entries are named ("PLC", "slave").
std::string used_twice(std::string_view noun, const std::string& name, uint32_t first_line);

// The claims of a driver whose maps are `read:` and `write:` lists: each read
// map provides a channel (region index = map index), each write map consumes
// a task output. `claim(map, write)` makes one map's ChannelClaim.
template <class Map, class Claim>
void claim_maps(DriverClaims& c, const std::vector<Map>& reads, const std::vector<Map>& writes, const Claim& claim) {
  for (const Map& m : reads) c.provides.push_back(claim(m, false));
  for (const Map& m : writes) c.consumes.push_back(claim(m, true));
}

}  // namespace rtplc::config
