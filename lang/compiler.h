// The compiler's public face: source text -> verified TaskImage, with
// diagnostics; plus the `check --explain` report. Safe to call from the live
// runtime (hot swap): it never exits, never prints, never touches global state.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "blocks/image.h"
#include "common/diagnostic.h"
#include "lang/flat_program.h"

namespace rtplc::lang {

// Where the editors' runtimes differ, whose behaviour a project gets
// (docs/plcopen.md, "Which editor's semantics"): the one its file header
// names (CODESYS's for a CODESYS export, MatIEC's for anything else:
// Beremiz, OpenPLC Editor, .st files), or the one the user chose.
enum class EditorSemantics : uint8_t { kFromHeader, kMatiec, kCodesys };

// "auto", "matiec" or "codesys" (the --semantics option and the task key);
// nullopt for anything else.
std::optional<EditorSemantics> parse_editor_semantics(std::string_view text);

struct CompileOptions {
  std::string name;                       // program name stored in the image
  std::optional<double> period_override;  // seconds; replaces stime (runtime config)
  bool batch = true;                      // group independent same-opcode blocks into runs
  // Output-buffer positions to keep (hot swap): output channels whose binding_key
  // appears here get that index; others follow after the last one. Empty: the
  // compiler's own order.
  std::vector<std::string> output_layout;
  // PLCopen XML: the task, program instance or program to run (empty: the
  // project's only one). docs/plcopen.md, "What runs".
  std::string entry;
  EditorSemantics semantics = EditorSemantics::kFromHeader;
};

struct CompileResult {
  DiagnosticList diags;
  CheckedProgram program;
  std::optional<TaskImage> image;  // present iff there were no errors
  bool ok() const { return image.has_value(); }
};

// A program in any registered language (lang/front_end.h), recognised by its
// text; a compiled task image is loaded and verified instead.
CompileResult compile_source(std::string_view source, const CompileOptions& options = {});

// True when `source` starts as a compiled task image does (kImageMagic). Every
// entry point above then loads and verifies it instead of compiling.
bool is_task_image(std::string_view source);

// Reads and compiles a file; I/O errors become diagnostics. The language is
// front_end_for(path, text): a registered extension first, then the text.
CompileResult compile_file(const std::string& path, const CompileOptions& options = {});

// Builds the image from an already checked program.
Result<TaskImage> build_image(const CheckedProgram& program, const CompileOptions& options,
                              uint64_t source_hash);

// The report of `rtplc check --explain`: execution order, delayed references,
// I/O bindings, state and parameter sizes, the run schedule.
std::string explain(const CompileResult& result);

// The largest program source any front end reads; real programs are KBs.
inline constexpr size_t kMaxSourceBytes = size_t{64} << 20;

// Reads a whole program source through the one bounded reader
// (read_file_bounded: regular files only, at most kMaxSourceBytes); nullopt
// (and `error`, starting with the path) on failure.
std::optional<std::string> read_text_file(const std::string& path, std::string* error);

}  // namespace rtplc::lang
