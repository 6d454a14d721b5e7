// IEC 61131-3 textual files (.st) as OpenPLC Editor and MatIEC write them
// (docs/st.md): TYPE ... END_TYPE, FUNCTION, FUNCTION_BLOCK and PROGRAM with
// their VAR sections, and CONFIGURATION / RESOURCE / TASK / PROGRAM ... WITH.
// The file is read into the same project model as a PLCopen XML project
// (lang/plcopen/project.h), whose ST bodies, calls, types and tasks the PLCopen
// lowering already runs: one ST implementation for both. Anything it cannot
// represent is an error at the construct's line:col naming it.
#pragma once

#include <optional>
#include <string_view>

#include "common/diagnostic.h"
#include "lang/plcopen/project.h"

namespace rtplc::lang::st {

// Reads a whole file; nullopt with at least one error when it cannot.
std::optional<plcopen::Project> read_st_file(std::string_view text, DiagnosticList& diags);

// True when the first word of `text`, after comments and pragmas, starts an
// IEC textual declaration (PROGRAM, FUNCTION_BLOCK, FUNCTION, TYPE,
// CONFIGURATION).
bool is_st_source(std::string_view text);

}  // namespace rtplc::lang::st
