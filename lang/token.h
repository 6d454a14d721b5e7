// Tokens of the control algorithm file (spec fbd-language.md). Each carries its
// position so every diagnostic can point at it with a caret.
#pragma once

#include <cstdint>
#include <string_view>

#include "common/diagnostic.h"

namespace rtplc::lang {

enum class Tok : uint8_t {
  kEof,
  kIdent,      // block name, stime, anything else alphabetic
  kRef,        // F12 D3 M4 N5 P1 — a block id or macro formal (letter + number)
  kDevice,     // p0 d1 c2 — a device address
  kNumber,     // 12  0.5  1e-3
  kString,     // "Label"
  kMacro,      // MACRO
  kEnd,        // END
  kReturn,     // RETURN (and the seed's spelling RETRUN)
  kSections,   // %%
  kLParen, kRParen, kComma, kEquals, kColon, kBar, kLBrace, kRBrace, kMinus, kPlus,
};

const char* tok_name(Tok t);

struct Token {
  Tok kind = Tok::kEof;
  SourcePos pos;
  uint32_t length = 0;
  std::string_view text;  // view into the source
  char letter = 0;        // kRef: F D M N P;  kDevice: p d c
  uint32_t number = 0;    // kRef / kDevice: the number after the letter
  double value = 0;       // kNumber
  bool number_overflow = false;  // kRef / kDevice: the number did not fit
};

}  // namespace rtplc::lang
