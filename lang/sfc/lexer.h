// Tokens of an SFC program (docs/sfc.md, "File layout"). Each token carries its
// position so every diagnostic points at it with a caret.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"

namespace rtplc::lang::sfc {

enum class Tok : uint8_t {
  kEof,
  kName,    // Fill, PBS, Fill.X, p0, SFC, STEP (keywords are names the parser knows)
  kNumber,  // 12  0.5  1e-3  -2, with an optional time unit: 5s 200ms T#1.5s
  kString,  // "valve1"
  kLParen,
  kRParen,
  kComma,
  kEquals,
  kColon,
  kStar,
  kArrow,
};

const char* tok_name(Tok t);

struct Token {
  Tok kind = Tok::kEof;
  SourcePos pos;
  uint32_t length = 0;
  std::string_view text;  // view into the source (a string without its quotes)
  double value = 0;       // kNumber, in seconds when it has a unit
  bool has_unit = false;  // kNumber written as a duration
};

// Never fails: a character it cannot read is reported and skipped. The last
// token is always kEof.
std::vector<Token> tokenize(std::string_view source, DiagnosticList& diags);

// True when the first word of `source` (after comments) is SFC: how the
// compiler tells an SFC program from an FBD one.
bool starts_with_sfc_keyword(std::string_view source);

}  // namespace rtplc::lang::sfc
