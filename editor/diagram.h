// The FBD editor's model (docs/editor.md): a control algorithm file as the
// block diagram the browser edits, and back. The text stays the one truth the
// compiler reads; a diagram is its statements in textual (= execution) order,
// each with its arguments as written and a cell on the seed's block grid, plus
// the macros. The layout sidecar (NAME.fbd.layout, the seed's "picture file")
// keeps only the cells.
//
// Everything here goes through the FBD front end's own lexer, parser and
// compiler: there is no second reading of the language. The diagram's derived
// fields (labels, devices, wires, feedback) are for the page; to_text reads
// only what was written.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "blocks/image.h"
#include "common/diagnostic.h"
#include "common/result.h"

namespace rtplc::editor {

// One argument as written: a reference (F2, D1, M3, N1, P2), a number, a
// device address part (p0, d1, c3) or a string (a label).
struct DArg {
  enum class Kind : uint8_t { kRef, kNumber, kDevice, kString };
  Kind kind = Kind::kNumber;
  std::string text;  // kRef "F2", kDevice "p0", kString the label
  double number = 0;
};

// One statement: `ID = kind(args)`, `kind(args)` or `ID = MACRO NAME(args)`.
struct DBlock {
  std::string id;  // "" for an output block (no result)
  std::string kind;
  bool macro = false;
  std::vector<DArg> args;
  int col = -1, row = -1;  // the block's cell; -1 until laid out
};

struct DMacro {
  std::string name;
  bool declared = false;  // MACRO NAME(a|d|p) before the first %%
  uint32_t n_analog = 0, n_digital = 0, n_params = 0;
  bool defined = false;  // its body after END
  std::vector<std::string> formals;  // M1.., N1.., P1..
  std::vector<DBlock> blocks;
  std::string ret;  // RETURN(Mi)
};

struct Diagram {
  int cols = 7, rows = 5;  // one screen of the seed's grid; the sheet grows past it
  std::optional<double> period_s;  // stime
  std::vector<DBlock> blocks;      // textual order = execution order
  std::vector<DMacro> macros;
};

// Reads FBD text into a diagram (cells unset). Syntax errors: the parser's
// diagnostics, rendered against `file_name` as `rtplc check` prints them.
Result<Diagram> from_text(std::string_view text, DiagnosticList* diags = nullptr);

// Where each block's statement is in the text to_text writes: for mapping the
// compiler's diagnostics back onto blocks and pins.
struct TextSpan {
  std::string macro;  // "" for the program body
  size_t block = 0;
  uint32_t line = 0;
  std::vector<uint32_t> arg_cols;  // 1-based column where each argument starts
};

// Writes the diagram as FBD text in the seed's format. `spans` (optional)
// gets where each block went.
std::string to_text(const Diagram& d, std::vector<TextSpan>* spans = nullptr);

// Places every block without a cell on the grid, as the seed's screen has
// them: input and set-point blocks on the top rows, output blocks on the
// bottom row, computation between in layers (a block one row below the
// lowest of its inputs, a one-cycle feedback reference not counted), each row
// ordered after where its inputs are; rows wider than the grid spill onto the
// next row. Blocks that already have a free cell keep it.
void auto_layout(Diagram& d);

// The layout sidecar: {"format": "rtplc-fbd-layout", "version": 1, "grid":
// {"cols", "rows"}, "cells": {KEY: [col, row]}}, KEY the block's id, else
// "out:LABEL", else "#INDEX" (and "MACRO/ID" inside a macro).
nlohmann::json layout_json(const Diagram& d);
// Applies a sidecar: cells of the keys it knows; others stay unset.
Result<void> apply_layout(Diagram& d, const nlohmann::json& layout);

// The diagram as the page takes it (docs/editor.md): blocks with their
// derived fields, wires, macros.
nlohmann::json diagram_json(const Diagram& d);
// The page's diagram back (only the written fields are read).
Result<Diagram> diagram_from_json(const nlohmann::json& j);

// A diagnostic of the compiler placed on the block (and argument) it concerns.
struct BlockDiagnostic {
  Diagnostic diag;
  std::string macro;  // "" in the program body
  std::optional<size_t> block;
  std::optional<size_t> arg;
};
struct CheckResult {
  std::string text;
  std::string rendered;  // as `rtplc check FILE` prints it
  std::vector<BlockDiagnostic> diagnostics;
  bool ok = false;
  uint64_t identity = 0;  // image_identity of the compiled image, when ok
};
// Compiles the diagram's text with the real compiler.
CheckResult check(const Diagram& d, const std::string& file_name = "diagram.fbd");
// The verdict as the page takes it: {"compiles", "text", "rendered",
// "identity" (hex), "diagnostics": [{"severity", "message", "line", "col",
// "macro", "block", "arg"}]}.
nlohmann::json check_json(const CheckResult& r);
// Diagnostics without blocks (a text that does not parse).
nlohmann::json diagnostics_json(const DiagnosticList& diags);

// Every primitive block of the registry: name, alias, group, signature
// (compute, device_in, setpoint, device_out), inputs with their kinds,
// parameters with defaults and ranges, state, summary, contract, errors.
nlohmann::json registry_json();

// What a program computes, independent of how its text is spaced: a hash of
// the compiled image with the source hash, the body check and the blocks' and
// bindings' line and column positions left out. Two texts with the same statements
// have the same identity; any change to a block, an argument, the order or a
// binding changes it.
uint64_t image_identity(const TaskImage& image);

}  // namespace rtplc::editor
