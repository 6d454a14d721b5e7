// Parser for SFC programs (docs/sfc.md, "File layout"): tokens -> Chart.
#pragma once

#include <vector>

#include "common/diagnostic.h"
#include "lang/sfc/ast.h"
#include "lang/sfc/lexer.h"

namespace rtplc::lang::sfc {

// Reports every syntax error it can find (it resynchronises at the next
// statement keyword) and returns what it could read.
Chart parse(const std::vector<Token>& tokens, DiagnosticList& diags);

}  // namespace rtplc::lang::sfc
