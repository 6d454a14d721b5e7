// The languages of rtplc as front ends over one compiler: each reads its own
// source into the compiler's one program form (lang/flat_program.h), and every
// one of them ends in the same checks (lang/program_checks.h) and the same image
// builder (compile_source). The compiler's entry points name no language: they
// ask front_end_for() which one reads a file.
//
// Adding a language is its folder under lang/ with a `const FrontEnd kFrontEnd`
// in its namespace, and one line in lang/front_ends.cpp (docs/architecture.md,
// "Languages").
#pragma once

#include <span>
#include <string_view>

#include "common/diagnostic.h"
#include "lang/flat_program.h"

namespace rtplc::lang {

struct CompileOptions;

struct FrontEnd {
  // Which of the common checks the compiler runs on what `read` returns.
  enum class Checks : uint8_t {
    kAll,                // check_flat_program, every diagnostic
    kAllButUnusedWarnings,  // the same without "computed but never used": the
                         // front end generates blocks nobody wrote by hand
    kRunByFrontEnd,      // `read` ran the common phases itself, interleaved
                         // with its own (the FBD checker's historical order)
  };

  const char* name = "";  // in messages: "FBD", "SFC", "PLCopen XML"
  // File name endings that are this language whatever the text holds (".sfc").
  std::span<const char* const> extensions;
  // True when `source` is this language whatever the file is called (its first
  // word, its XML root). Null for the fallback.
  bool (*recognises)(std::string_view source) = nullptr;
  // CompileOptions::entry chooses a task or program inside a source of it.
  bool has_entries = false;
  Checks checks = Checks::kAll;
  // The program as the compiler's one form; errors and warnings into `diags`.
  CheckedProgram (*read)(std::string_view source, const CompileOptions& options, DiagnosticList& diags) = nullptr;
};

// Adds a front end (registration order is the order of recognition). One whose
// name is there already is ignored.
void register_front_end(const FrontEnd* front_end);

// Every front end, in registration order (the built-in ones first).
std::span<const FrontEnd* const> front_ends();

// The one rule: the front end that registered the file's extension; else the
// first, in registration order, that recognises the text; else the fallback (the
// front end without `recognises`). `path` may be empty (a source from memory).
const FrontEnd& front_end_for(std::string_view path, std::string_view source);

}  // namespace rtplc::lang
