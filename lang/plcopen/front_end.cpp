// The PLCopen XML front end (docs/plcopen.md): a TC6 project, recognised by the
// .xml extension or by its <project> root; CompileOptions::entry chooses its
// task or program. Its lowering writes copies nobody reads (a variable's
// end-of-cycle value), so "computed but never used" is not said of it.
#include "lang/compiler.h"
#include "lang/front_end.h"
#include "lang/plcopen/import.h"

namespace rtplc::lang::plcopen {
namespace {

constexpr const char* kExtensions[] = {".xml"};

CheckedProgram read_plcopen(std::string_view source, const CompileOptions& options, DiagnosticList& diags) {
  ImportOptions io;
  io.entry = options.entry;
  io.semantics = options.semantics;
  return import_plcopen(source, io, diags).program;
}

}  // namespace

extern const FrontEnd kFrontEnd;
const FrontEnd kFrontEnd{
    .name = "PLCopen XML",
    .extensions = kExtensions,
    .recognises = is_plcopen_source,
    .has_entries = true,
    .checks = FrontEnd::Checks::kAllButUnusedWarnings,
    .read = read_plcopen,
};

}  // namespace rtplc::lang::plcopen
