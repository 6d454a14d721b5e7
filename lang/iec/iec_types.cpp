// The elementary type table (lang/iec/iec_types.h).
#include "lang/iec/iec_types.h"

#include <cctype>
#include <cmath>

namespace rtplc::lang::iec {
namespace {

using T = IecType;
//                         name     type        bits signed int   bits  real
constexpr IecTypeInfo kTypes[] = {
    {"BOOL", T::kBool, 1, false, false, false, false},
    {"SINT", T::kSint, 8, true, true, false, false},
    {"INT", T::kInt, 16, true, true, false, false},
    {"DINT", T::kDint, 32, true, true, false, false},
    {"LINT", T::kLint, 64, true, true, false, false},
    {"USINT", T::kUsint, 8, false, true, false, false},
    {"UINT", T::kUint, 16, false, true, false, false},
    {"UDINT", T::kUdint, 32, false, true, false, false},
    {"ULINT", T::kUlint, 64, false, true, false, false},
    {"BYTE", T::kByte, 8, false, true, true, false},
    {"WORD", T::kWord, 16, false, true, true, false},
    {"DWORD", T::kDword, 32, false, true, true, false},
    {"LWORD", T::kLword, 64, false, true, true, false},
    {"REAL", T::kReal, 32, true, false, false, true},
    {"LREAL", T::kLreal, 64, true, false, false, true},
    {"TIME", T::kTime, 64, true, false, false, false},
    {"DATE", T::kDate, 64, true, false, false, false},
    {"TOD", T::kTod, 64, true, false, false, false},
    {"DT", T::kDt, 64, true, false, false, false},
};

bool same_ignoring_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(a[i])) !=
        std::toupper(static_cast<unsigned char>(b[i]))) {
      return false;
    }
  }
  return true;
}

}  // namespace

double IecTypeInfo::min_value() const {
  if (type == T::kBool) return 0;
  if (!integer) return -1e300;
  return is_signed ? -std::ldexp(1.0, bits - 1) : 0.0;
}

double IecTypeInfo::max_value() const {
  if (type == T::kBool) return 1;
  if (!integer) return 1e300;
  return is_signed ? std::ldexp(1.0, bits - 1) - 1 : std::ldexp(1.0, bits) - 1;
}

const IecTypeInfo& type_info(IecType t) {
  return kTypes[static_cast<uint8_t>(t)];
}

const IecTypeInfo* find_iec_type(std::string_view name) {
  if (same_ignoring_case(name, "TIME_OF_DAY")) return &type_info(T::kTod);
  if (same_ignoring_case(name, "DATE_AND_TIME")) return &type_info(T::kDt);
  for (const IecTypeInfo& t : kTypes) {
    if (same_ignoring_case(name, t.name)) return &t;
  }
  return nullptr;
}

bool range_contains(const IecTypeInfo& to, const IecTypeInfo& from) {
  if (!to.integer) return true;  // a real (or TIME) holds any of our integers as a double
  if (!from.integer) return from.type == T::kBool;
  return to.min_value() <= from.min_value() && from.max_value() <= to.max_value();
}

}  // namespace rtplc::lang::iec
