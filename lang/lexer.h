// Lexer: source text -> tokens. Skips /* */ and // comments; reports bad
// characters, unterminated strings/comments and malformed numbers with positions
// and keeps going, so one run shows every problem.
#pragma once

#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "lang/token.h"

namespace rtplc::lang {

// Tokenises `source`. Always ends with a kEof token.
std::vector<Token> tokenize(std::string_view source, DiagnosticList& diags);

}  // namespace rtplc::lang
