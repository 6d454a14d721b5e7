// What the entries of every driver's channel maps share (the `read:`/`write:`
// lists of the s7 and modbus kinds, the `expose:` list of modbus-server, and
// the next kinds'): a linear scaling between the peer's raw value and the
// engineering value, and for writes when to send. One parser each, so every
// kind says the same thing about the same key.
#pragma once

#include <cstdint>
#include <functional>

#include "common/diagnostic.h"

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

}  // namespace rtplc::config
