// The FBD front end (the KIST FBD text format, docs/language.md): lexer, parser,
// macro expander and the FBD checker, which runs the common checks itself in
// its historical order. It is the fallback: a source no other language claims.
#include "lang/compiler.h"
#include "lang/front_end.h"
#include "lang/lexer.h"
#include "lang/macro_expander.h"
#include "lang/parser.h"

namespace rtplc::lang::fbd {
namespace {

CheckedProgram read_fbd(std::string_view source, const CompileOptions&, DiagnosticList& diags) {
  const std::vector<Token> tokens = tokenize(source, diags);
  const Program program = parse(tokens, diags);
  return check_program(program, diags);
}

}  // namespace

extern const FrontEnd kFrontEnd;
const FrontEnd kFrontEnd{
    .name = "FBD",
    .extensions = {},
    .recognises = nullptr,
    .has_entries = false,
    .checks = FrontEnd::Checks::kRunByFrontEnd,
    .read = read_fbd,
};

}  // namespace rtplc::lang::fbd
