// Sparkplug B payloads as rtplc writes and reads them (docs/sparkplug.md,
// "Metrics"): the data types, the Quality codes a host reads, the encoding of
// a value into a metric, and the decoding of a command (NCMD/DCMD) into what
// it asks, refusing anything malformed, oversized or of a type we cannot take.
// Used on the driver's link thread only (it allocates).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/quality.h"
#include "common/result.h"
#include "sparkplug_b.pb.h"

namespace rtplc::sparkplug {

// Sparkplug 3.0 data type codes (the ones rtplc sends or accepts).
enum class DataType : uint32_t {
  kInt8 = 1, kInt16 = 2, kInt32 = 3, kInt64 = 4,
  kUInt8 = 5, kUInt16 = 6, kUInt32 = 7, kUInt64 = 8,
  kFloat = 9, kDouble = 10, kBoolean = 11, kString = 12,
};
const char* datatype_name(uint32_t code);

// The `Quality` property (Int32) of a metric, as Ignition's MQTT Engine reads
// it (Ignition 8 quality codes): good 192; stale -> Bad_Stale; bad -> Bad. A
// forced value is the operator's, not the plant's: Good, with the boolean
// property `Forced`.
inline constexpr int32_t kQualityGood = 192;
inline constexpr int32_t kQualityBad = static_cast<int32_t>(0x80000200u);       // -2147483136
inline constexpr int32_t kQualityBadStale = static_cast<int32_t>(0x80000204u);  // -2147483132
int32_t quality_code(Quality q);
const char* quality_code_name(int32_t code);

using pb::Payload;
using Metric = pb::Payload_Metric;

// One value as a metric: datatype Double or Boolean, its value, timestamp and
// the Quality property (and Forced when forced). `name` or `alias` as asked.
void set_metric_value(Metric& m, bool digital, double value, Quality q, bool forced, uint64_t timestamp_ms);
// A node metric of another type.
void set_int64(Metric& m, int64_t v);
void set_uint64(Metric& m, uint64_t v);
void set_bool(Metric& m, bool v);
void set_string(Metric& m, const std::string& v);

// What one metric of a command asks.
struct CommandMetric {
  std::string name;         // "" when it names itself by alias
  uint64_t alias = 0;
  bool has_alias = false;
  uint32_t datatype = 0;
  double value = 0;         // numbers and booleans (1/0)
  bool has_value = false;   // false: null, a string, a data set, ... (refused by the caller)
  std::string why_no_value; // when !has_value
};

// Decodes an NCMD/DCMD payload of at most `max_bytes`. An error names what is
// wrong (too large, not a Sparkplug payload, no metrics).
Result<std::vector<CommandMetric>> decode_command(std::string_view bytes, size_t max_bytes);

// The metric's value as a number, by its declared datatype and the field it
// uses, with the sign traps handled (Int32 in uint32, Int64 in uint64); false
// with a reason for a type or field we cannot take.
bool metric_number(const Metric& m, double& out, std::string& why);

// One line per metric, for `rtplc sparkplug listen`.
std::string describe_payload(const Payload& p, bool with_properties = true);

}  // namespace rtplc::sparkplug
