// The IEC 61131-3 elementary types as rtplc carries them (docs/language.md,
// "IEC 61131-3 types and standard blocks"): BOOL is a digital value, every
// other type an analog double; an integer type's range is kept by `wrap`.
#pragma once

#include <cstdint>
#include <string_view>

#include "blocks/registry.h"

namespace rtplc::lang::iec {

enum class IecType : uint8_t {
  kBool,
  kSint,
  kInt,
  kDint,
  kLint,
  kUsint,
  kUint,
  kUdint,
  kUlint,
  kByte,
  kWord,
  kDword,
  kLword,
  kReal,
  kLreal,
  kTime,
  // Points in time, in seconds like TIME (docs/st.md, "Dates and times of
  // day"): DATE and DT since 1970-01-01 (kept on the microsecond grid), TOD
  // since midnight. Not in the X_TO_Y table: DT_TO_DATE, DT_TO_TOD and the
  // date arithmetic functions are their own.
  kDate,
  kTod,
  kDt,
};

struct IecTypeInfo {
  const char* name;  // "INT"
  IecType type;
  uint8_t bits;  // 1 for BOOL; 32/64 for REAL/LREAL; 64 for TIME and the dates
  bool is_signed;
  bool integer;     // SINT..ULINT and the bit strings BYTE..LWORD
  bool bit_string;  // BYTE..LWORD
  bool real;        // REAL, LREAL
  Kind kind() const { return type == IecType::kBool ? Kind::kDigital : Kind::kAnalog; }
  // The type's range as doubles (integers only; +-1e300 otherwise).
  double min_value() const;
  double max_value() const;
};

const IecTypeInfo& type_info(IecType t);

// Case-insensitive ("int", "INT"; "TIME_OF_DAY" and "DATE_AND_TIME" are TOD and
// DT); nullptr if the name is not an elementary type rtplc supports (STRING).
const IecTypeInfo* find_iec_type(std::string_view name);

// True when every value of `from` is a value of `to` (no wrap needed).
bool range_contains(const IecTypeInfo& to, const IecTypeInfo& from);

// The grid a variable of type `t` takes its value on, in steps per second: 1e9
// (nanoseconds) for TIME and TOD, 1e6 (microseconds) for DATE and DT, whose
// seconds since 1970 leave a double no room for nanoseconds; 0 for the others.
inline double time_grid(IecType t) {
  if (t == IecType::kTime || t == IecType::kTod) return 1e9;
  if (t == IecType::kDate || t == IecType::kDt) return 1e6;
  return 0;
}

}  // namespace rtplc::lang::iec
