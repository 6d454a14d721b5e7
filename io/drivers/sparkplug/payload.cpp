// Sparkplug B payloads (see payload.h).
#include "io/drivers/sparkplug/payload.h"

#include <fmt/format.h>

#include <cmath>

namespace rtplc::sparkplug {

const char* datatype_name(uint32_t code) {
  static const char* const kNames[] = {"Unknown", "Int8",   "Int16",  "Int32",   "Int64",    "UInt8",
                                       "UInt16",  "UInt32", "UInt64", "Float",   "Double",   "Boolean",
                                       "String",  "DateTime", "Text", "UUID",    "DataSet",  "Bytes",
                                       "File",    "Template", "PropertySet", "PropertySetList"};
  return code < std::size(kNames) ? kNames[code] : "?";
}

int32_t quality_code(Quality q) {
  switch (q) {
    case Quality::kGood:
    case Quality::kForced: return kQualityGood;
    case Quality::kStale: return kQualityBadStale;
    case Quality::kBad: break;
  }
  return kQualityBad;
}

const char* quality_code_name(int32_t code) {
  switch (code) {
    case kQualityGood: return "Good";
    case kQualityBad: return "Bad";
    case kQualityBadStale: return "Bad_Stale";
    default: return "?";
  }
}

namespace {

void add_property_int32(Payload::PropertySet& ps, const char* key, int32_t v) {
  ps.add_keys(key);
  Payload::PropertyValue* pv = ps.add_values();
  pv->set_type(static_cast<uint32_t>(DataType::kInt32));
  pv->set_int_value(static_cast<uint32_t>(v));  // the two's-complement bits (payload.h)
}

void add_property_bool(Payload::PropertySet& ps, const char* key, bool v) {
  ps.add_keys(key);
  Payload::PropertyValue* pv = ps.add_values();
  pv->set_type(static_cast<uint32_t>(DataType::kBoolean));
  pv->set_boolean_value(v);
}

}  // namespace

void set_metric_value(Metric& m, bool digital, double value, Quality q, bool forced, uint64_t timestamp_ms) {
  m.set_timestamp(timestamp_ms);
  m.set_datatype(static_cast<uint32_t>(digital ? DataType::kBoolean : DataType::kDouble));
  if (!std::isfinite(value) && !digital) {
    // No number to give: a null value, and the quality says why.
    m.set_is_null(true);
    m.clear_value();
  } else if (digital) {
    m.set_boolean_value(value != 0);
  } else {
    m.set_double_value(value);
  }
  Payload::PropertySet* ps = m.mutable_properties();
  ps->Clear();
  add_property_int32(*ps, "Quality", quality_code(q));
  if (forced) add_property_bool(*ps, "Forced", true);
}

void set_int64(Metric& m, int64_t v) {
  m.set_datatype(static_cast<uint32_t>(DataType::kInt64));
  m.set_long_value(static_cast<uint64_t>(v));
}
void set_uint64(Metric& m, uint64_t v) {
  m.set_datatype(static_cast<uint32_t>(DataType::kUInt64));
  m.set_long_value(v);
}
void set_bool(Metric& m, bool v) {
  m.set_datatype(static_cast<uint32_t>(DataType::kBoolean));
  m.set_boolean_value(v);
}
void set_string(Metric& m, const std::string& v) {
  m.set_datatype(static_cast<uint32_t>(DataType::kString));
  m.set_string_value(v);
}

bool metric_number(const Metric& m, double& out, std::string& why) {
  if (m.has_is_null() && m.is_null()) {
    why = "its value is null";
    return false;
  }
  const uint32_t t = m.datatype();
  auto need = [&](Metric::ValueCase c, const char* field) {
    if (m.value_case() == c) return true;
    why = fmt::format("its datatype {} needs {}, which it lacks", datatype_name(t), field);
    return false;
  };
  switch (static_cast<DataType>(t)) {
    case DataType::kInt8:
    case DataType::kInt16:
    case DataType::kInt32:
      if (!need(Metric::kIntValue, "int_value")) return false;
      out = static_cast<double>(static_cast<int32_t>(m.int_value()));
      if (t == 1 && (out < -128 || out > 127)) break;
      if (t == 2 && (out < -32768 || out > 32767)) break;
      return true;
    case DataType::kUInt8:
    case DataType::kUInt16:
    case DataType::kUInt32:
      if (!need(Metric::kIntValue, "int_value")) return false;
      out = static_cast<double>(m.int_value());
      if (t == 5 && out > 255) break;
      if (t == 6 && out > 65535) break;
      return true;
    case DataType::kInt64:
      if (!need(Metric::kLongValue, "long_value")) return false;
      out = static_cast<double>(static_cast<int64_t>(m.long_value()));
      return true;
    case DataType::kUInt64:
      if (!need(Metric::kLongValue, "long_value")) return false;
      out = static_cast<double>(m.long_value());
      return true;
    case DataType::kFloat:
      if (!need(Metric::kFloatValue, "float_value")) return false;
      out = m.float_value();
      if (!std::isfinite(out)) {
        why = "its value is not a finite number";
        return false;
      }
      return true;
    case DataType::kDouble:
      if (!need(Metric::kDoubleValue, "double_value")) return false;
      out = m.double_value();
      if (!std::isfinite(out)) {
        why = "its value is not a finite number";
        return false;
      }
      return true;
    case DataType::kBoolean:
      if (!need(Metric::kBooleanValue, "boolean_value")) return false;
      out = m.boolean_value() ? 1 : 0;
      return true;
    default:
      why = fmt::format("its datatype {} ({}) is not a number", datatype_name(t), t);
      return false;
  }
  why = fmt::format("its value is outside the range of {}", datatype_name(t));
  return false;
}

Result<std::vector<CommandMetric>> decode_command(std::string_view bytes, size_t max_bytes) {
  if (bytes.size() > max_bytes) {
    return make_error(fmt::format("a command of {} bytes is larger than the {} taken", bytes.size(), max_bytes));
  }
  Payload p;
  if (!p.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return make_error("not a Sparkplug B payload (protobuf does not decode)");
  }
  if (p.metrics_size() == 0) return make_error("a command without metrics");
  if (p.metrics_size() > 4096) return make_error(fmt::format("a command of {} metrics (at most 4096)", p.metrics_size()));
  std::vector<CommandMetric> out;
  out.reserve(static_cast<size_t>(p.metrics_size()));
  for (const Metric& m : p.metrics()) {
    CommandMetric c;
    c.name = m.name();
    c.has_alias = m.has_alias();
    c.alias = m.alias();
    c.datatype = m.datatype();
    c.has_value = metric_number(m, c.value, c.why_no_value);
    if (c.name.empty() && !c.has_alias) {
      c.has_value = false;
      c.why_no_value = "it has neither a name nor an alias";
    }
    out.push_back(std::move(c));
  }
  return out;
}

std::string describe_payload(const Payload& p, bool with_properties) {
  std::string s = fmt::format("seq={} timestamp={} metrics={}", p.has_seq() ? std::to_string(p.seq()) : "-",
                              p.timestamp(), p.metrics_size());
  for (const Metric& m : p.metrics()) {
    s += "\n  ";
    s += m.has_name() ? m.name() : fmt::format("alias {}", m.alias());
    if (m.has_name() && m.has_alias()) s += fmt::format(" (alias {})", m.alias());
    s += fmt::format(" {}", datatype_name(m.datatype()));
    double v = 0;
    std::string why;
    if (m.value_case() == Metric::kStringValue) {
      s += " = \"" + m.string_value() + "\"";
    } else if (m.value_case() == Metric::kBooleanValue) {
      s += m.boolean_value() ? " = true" : " = false";
    } else if (metric_number(m, v, why)) {
      s += fmt::format(" = {}", v);
    } else {
      s += " = (" + why + ")";
    }
    if (m.is_historical()) s += " historical";
    if (with_properties && m.has_properties()) {
      const Payload::PropertySet& ps = m.properties();
      for (int i = 0; i < ps.keys_size() && i < ps.values_size(); ++i) {
        const Payload::PropertyValue& pv = ps.values(i);
        if (pv.value_case() == Payload::PropertyValue::kIntValue) {
          const int32_t code = static_cast<int32_t>(pv.int_value());
          s += fmt::format(" {}={}", ps.keys(i), code);
          if (ps.keys(i) == "Quality") s += fmt::format("({})", quality_code_name(code));
        } else if (pv.value_case() == Payload::PropertyValue::kBooleanValue) {
          s += fmt::format(" {}={}", ps.keys(i), pv.boolean_value());
        }
      }
    }
  }
  return s;
}

}  // namespace rtplc::sparkplug
