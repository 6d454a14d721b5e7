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
};

struct IecTypeInfo {
  const char* name;  // "INT"
  IecType type;
  uint8_t bits;  // 1 for BOOL; 32/64 for REAL/LREAL; 64 for TIME
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

// Case-insensitive ("int", "INT"); nullptr if the name is not an elementary type
// rtplc supports (STRING, DATE and the like).
const IecTypeInfo* find_iec_type(std::string_view name);

// True when every value of `from` is a value of `to` (no wrap needed).
bool range_contains(const IecTypeInfo& to, const IecTypeInfo& from);

}  // namespace rtplc::lang::iec
