// Parser: tokens -> Program (ast.h). Recursive descent, one function per grammar
// rule with the rule above it. On a syntax error it reports what was expected,
// skips to the next line and goes on, so one run lists several errors.
#pragma once

#include <vector>

#include "common/diagnostic.h"
#include "lang/ast.h"
#include "lang/token.h"

namespace rtplc::lang {

Program parse(const std::vector<Token>& tokens, DiagnosticList& diags);

}  // namespace rtplc::lang
