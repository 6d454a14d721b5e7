// The string opcodes' semantics (ops.h, "Strings"; docs/st.md, "Strings"),
// written once for both interpreter bodies and for the compilers' constant
// folding. A string value lives in the value arena: V[at] its length, then one
// character code per slot. Nothing here allocates: texts pass through
// fixed buffers of kMaxStringLength bytes on the stack.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "blocks/image.h"
#include "blocks/ops.h"

namespace rtplc {

// SFmt's and SParse's type codes (P[1] of SFmt, P[0] of SParse): what the
// number is, so its text is the type's (`16#FF` for a BYTE, `T#1s` for a TIME).
enum class StringFormat : uint8_t {
  kSigned,    // SINT .. LINT
  kUnsigned,  // USINT .. ULINT
  kBits,      // BYTE .. LWORD
  kReal,      // REAL
  kLreal,     // LREAL
  kBool,
  kTime,      // TIME (the value in seconds)
  kDate,      // DATE, TOD, DT (seconds since 1970-01-01 / since midnight)
  kTod,
  kDt,
};
static_assert(static_cast<uint32_t>(StringFormat::kDt) + 1 == kStringFormats);

// The dialect of a conversion's text (SFmt P[2], SParse P[1]): what the
// project's editor's runtime writes and reads (docs/st.md, "Strings").
enum class StringDialect : uint8_t { kMatiec, kCodesys };

// Runs one string instruction on the value arena V of n_values slots; P its
// prepared parameters. Reads a length as at most what the arena holds after it.
void string_op(const Instr& I, double* V, uint32_t n_values, const double* P) noexcept;

// The texts of SFmt and the numbers of SParse, for folding and tests.
std::string format_for_string(double v, StringFormat f, StringDialect d);
double parse_from_string(std::string_view s, StringFormat f, StringDialect d);

// The string value at V[at] as text (monitor, watch, CSV): a STRING's bytes
// (a code above 255 as '?'), a WSTRING's code units as UTF-8.
std::string string_value(const double* V, uint32_t n_values, uint32_t at, bool wide = false);
// A WSTRING literal's UTF-8 text as UTF-16 code units (a broken sequence U+FFFD).
std::vector<uint16_t> utf16_units(std::string_view utf8);
// UTF-16 code units as UTF-8 (a pair as one character; a lone half, which a
// literal's $D800 may write, as its own three bytes so utf16_units gives it back).
std::string utf8_of_units(const std::vector<uint16_t>& units);
// Whether the string an instruction writes is a WSTRING (an SCopy or an SConst
// says so in its parameters; blocks/ops.h): how to show it.
bool writes_wide_string(const Instr& I, const double* prepared);

}  // namespace rtplc
