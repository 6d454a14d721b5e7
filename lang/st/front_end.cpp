// The ST front end (docs/st.md): an IEC 61131-3 textual file, recognised by the
// .st extension or by its first declaration, read into the PLCopen project
// model and lowered by the PLCopen front end's lowering (one ST implementation);
// CompileOptions::entry chooses its task, program instance or program.
#include "lang/compiler.h"
#include "lang/front_end.h"
#include "lang/plcopen/import.h"
#include "lang/st/st_file.h"

namespace rtplc::lang::st {
namespace {

constexpr const char* kExtensions[] = {".st"};

CheckedProgram read_st(std::string_view source, const CompileOptions& options, DiagnosticList& diags) {
  std::optional<plcopen::Project> project = read_st_file(source, diags);
  if (!project) return {};
  plcopen::ImportOptions io;
  io.entry = options.entry;
  io.semantics = options.semantics;
  return plcopen::import_project(*project, io, diags).program;
}

}  // namespace

extern const FrontEnd kFrontEnd;
const FrontEnd kFrontEnd{
    .name = "ST",
    .extensions = kExtensions,
    .recognises = is_st_source,
    .has_entries = true,
    .checks = FrontEnd::Checks::kAllButUnusedWarnings,
    .read = read_st,
};

}  // namespace rtplc::lang::st
