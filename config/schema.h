// The schema of the runtime configuration (spec runtime.md, "Configuration";
// style.md practice 9): one table per section giving each key its type,
// default, allowed values and meaning. The loader takes its unknown-key errors,
// "did you mean" hints, required keys and range checks from these rows, and
// docs/config.md is generated from them, so the three cannot disagree.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace rtplc::config {

enum class ValueType : uint8_t {
  kSection,      // a map of further keys (the runtime section)
  kList,         // a list of maps of the section named by `item`
  kLabelMap,     // a map label -> number
  kLimitMap,     // a map label -> {min: number, max: number}
  kName,         // [A-Za-z0-9_-]{1,31}
  kPath,         // a file path, relative to the config file's folder
  kDuration,     // "10ms", "250us", "0.5s" or seconds; min/max in seconds
  kInteger,      // whole number in [min, max]
  kIntegerPair,  // [lo, hi], each in [min, max], lo <= hi
  kBool,         // true or false
  kChoice,       // one word of `choices` ("skip|stop")
  kChannel,      // "pN.dN.cN"
  kPlantModel,   // a plant spec of io/plant.h make_plant()
  kDriverKind,   // a kind of config/driver_kinds.h
  kText,         // a non-empty string whose syntax its kind checks (an S7 item, an IPv4 address)
  kReal,         // a finite number
  kBlockSelection,  // `all`, `none` or a list of block names
};

struct KeySpec {
  const char* key;
  ValueType type;
  bool required;
  double min;  // integers, durations (s), pairs; list lengths for kList
  double max;
  const char* choices;       // kChoice: "a|b"; kList: the item section's id
  const char* default_text;  // what applies when the key is absent ("" = nothing)
  const char* meaning;       // one line
};

struct SectionSpec {
  const char* id;     // "task"; also what the docs' heading names
  const char* noun;   // for messages: "unknown key 'x' in a task"
  const char* title;  // docs heading
  const char* intro;  // docs paragraph (markdown), may be ""
  std::span<const KeySpec> keys;
};

// The sections of the file. Driver kinds add their own (config/driver_kinds.h).
const SectionSpec& top_section();
const SectionSpec& runtime_section();
const SectionSpec& task_section();
const SectionSpec& driver_section();  // keys every driver has, whatever its kind

const KeySpec* find_key(const SectionSpec& s, std::string_view key);

// The short type name of the docs' tables: "duration", "integer", ...
const char* type_name(ValueType t);
// "a name", "a duration such as 10ms", ... for "expected ..." messages.
std::string describe_type(const KeySpec& k);
// The allowed values, generated from the row: "1..98", "10us..3600s", "skip | stop".
std::string describe_allowed(const KeySpec& k);

}  // namespace rtplc::config
