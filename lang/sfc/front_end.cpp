// The SFC front end (docs/sfc.md): a chart, recognised by the .sfc extension or
// by its first word SFC, built into ordinary blocks; the compiler then runs every
// common check on them.
#include "lang/compiler.h"
#include "lang/front_end.h"
#include "lang/sfc/builder.h"
#include "lang/sfc/lexer.h"

namespace rtplc::lang::sfc {
namespace {

constexpr const char* kExtensions[] = {".sfc"};

CheckedProgram read_sfc(std::string_view source, const CompileOptions&, DiagnosticList& diags) {
  return compile_to_flat(source, diags);
}

}  // namespace

extern const FrontEnd kFrontEnd;
const FrontEnd kFrontEnd{
    .name = "SFC",
    .extensions = kExtensions,
    .recognises = starts_with_sfc_keyword,
    .has_entries = false,
    .checks = FrontEnd::Checks::kAll,
    .read = read_sfc,
};

}  // namespace rtplc::lang::sfc
