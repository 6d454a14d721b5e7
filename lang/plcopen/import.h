// PLCopen TC6 XML -> the language-neutral flat program (docs/plcopen.md). The
// front end behind `rtplc check/sim/run` for a .xml file: reads the project
// (project.h), picks the program instances of one task, lowers every POU
// instance's body (FBD, LD, SFC, ST, IL) into primitive blocks with instance-path names,
// for the one set of checks (lang/program_checks.h), which compile_source runs.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "lang/compiler.h"
#include "lang/flat_program.h"

namespace rtplc::lang::plcopen {

struct ImportOptions {
  // What to run: a task name (its program instances, in order), a pouInstance
  // name, or a program POU name. Empty: the only task of the project, or its
  // only program when it has no configuration.
  std::string entry;
  EditorSemantics semantics = EditorSemantics::kFromHeader;
};

// What was imported: the flat program (for check_flat_program) and what runs.
struct ImportResult {
  CheckedProgram program;
  std::string entry;              // what was chosen
  std::vector<std::string> instances;  // program instance paths, in run order
  int priority = -1;              // the task's priority, -1 when none
};

ImportResult import_plcopen(std::string_view xml, const ImportOptions& options, DiagnosticList& diags);

struct Project;
// The same from a project already read (an IEC 61131-3 textual file read by
// lang/st/ fills the same model).
ImportResult import_project(const Project& project, const ImportOptions& options, DiagnosticList& diags);

// True when `text` looks like a PLCopen project (an XML document whose root is
// <project>), so compile_source() can dispatch on content.
bool is_plcopen_source(std::string_view text);

}  // namespace rtplc::lang::plcopen
