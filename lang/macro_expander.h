// The FBD front end's checking stage: Program (as written, lang/ast.h) ->
// CheckedProgram (lang/flat_program.h). It expands macros with their FBD rules
// (spec fbd-language.md "Macros": declarations, arity, RETURN, recursion,
// per-call state, M/N/P names) and binds each primitive call's written
// arguments, then runs the language-neutral checks of lang/program_checks.h on
// the flat result. Other front ends skip this file and call
// check_flat_program() on their own flat blocks.
#pragma once

#include "common/diagnostic.h"
#include "lang/ast.h"
#include "lang/flat_program.h"

namespace rtplc::lang {

// Checks and expands `prog`. Errors and warnings go to `diags`; the result is
// meaningful only when diags has no errors.
CheckedProgram check_program(const Program& prog, DiagnosticList& diags);

}  // namespace rtplc::lang
