// Source positions and compiler-style diagnostics: "file:line:col: error: ...",
// the offending line, and a caret under the column. Used by the FBD compiler and
// the YAML config loader so every load-time error reads the same way.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace rtplc {

struct SourcePos {
  uint32_t line = 0;  // 1-based; 0 = no position
  uint32_t col = 0;   // 1-based
};

enum class Severity : uint8_t { kError, kWarning, kNote };

struct Diagnostic {
  Severity severity = Severity::kError;
  SourcePos pos;
  uint32_t length = 1;  // caret width
  std::string message;
};

// Collects diagnostics for one source text. Stops recording past a limit so a
// pathological input cannot flood memory, but keeps counting.
class DiagnosticList {
 public:
  static constexpr size_t kMaxRecorded = 100;

  void error(SourcePos pos, std::string msg, uint32_t length = 1);
  void warning(SourcePos pos, std::string msg, uint32_t length = 1);
  void note(SourcePos pos, std::string msg, uint32_t length = 1);

  size_t error_count() const { return errors_; }
  size_t warning_count() const { return warnings_; }
  // Diagnostics counted but not kept (past kMaxRecorded); render() says how many.
  size_t dropped_count() const { return dropped_; }
  bool has_errors() const { return errors_ > 0; }
  const std::vector<Diagnostic>& items() const { return items_; }

  // Renders every diagnostic against its source. `color` adds ANSI colours.
  std::string render(std::string_view file_name, std::string_view source, bool color = false) const;

 private:
  void add(Severity s, SourcePos pos, std::string msg, uint32_t length);
  std::vector<Diagnostic> items_;
  size_t errors_ = 0;
  size_t warnings_ = 0;
  size_t dropped_ = 0;
};

// `text` safe to print on a terminal: printable ASCII, tabs and valid UTF-8 as
// they are, every other byte (controls, NUL, DEL, broken UTF-8) as \xNN, so
// escapes in a binary file cannot reach the terminal and a NUL cannot cut the
// output short. Newlines are kept only when asked.
std::string escape_for_terminal(std::string_view text, bool keep_newlines = false);

// Returns line `line` (1-based) of `source` without its newline, or "" if out of range.
std::string_view source_line(std::string_view source, uint32_t line);

// Damerau-free Levenshtein distance, for "did you mean" hints.
size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace rtplc
