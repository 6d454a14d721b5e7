// The syntax tree of a control algorithm file, as written (before macro
// expansion and checking). Every node keeps the position of what it came from.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/diagnostic.h"

namespace rtplc::lang {

// A block id or macro formal as written: F12, D3, M4, N5, P1.
struct Ref {
  char letter = 0;
  uint32_t number = 0;
  SourcePos pos;
  uint32_t length = 1;
  std::string text() const { return std::string(1, letter) + std::to_string(number); }
};

struct Arg {
  enum class Kind : uint8_t { kRef, kNumber, kDevice, kString };
  Kind kind = Kind::kNumber;
  Ref ref;                // kRef
  double number = 0;      // kNumber (sign folded in)
  char device = 0;        // kDevice: p d c
  uint32_t device_no = 0; // kDevice
  std::string text;       // kString (without quotes)
  SourcePos pos;
  uint32_t length = 1;
};

// `ID = block(args)`, `block(args)`, or `ID = MACRO NAME(args)`.
struct Call {
  bool has_target = false;
  Ref target;
  bool is_macro = false;
  std::string name;
  SourcePos name_pos;
  uint32_t name_length = 1;
  std::vector<Arg> args;
  SourcePos pos;  // start of the statement
};

// `MACRO NAME (l:m:n)` in the declaration section.
struct MacroDecl {
  std::string name;
  SourcePos pos;
  uint32_t name_length = 1;
  uint32_t n_analog = 0;
  uint32_t n_digital = 0;
  uint32_t n_params = 0;
};

// `MACRO NAME (M1, ..., N1, ..., P1, ...) { calls... RETURN(Mi) }`.
struct MacroDef {
  std::string name;
  SourcePos pos;
  uint32_t name_length = 1;
  std::vector<Ref> formals;
  std::vector<Call> body;
  bool has_return = false;
  Ref ret;
  SourcePos close_pos;  // the closing brace, for "RETURN missing"
};

struct Program {
  std::vector<MacroDecl> decls;
  std::vector<Call> body;
  std::vector<MacroDef> defs;
  bool has_stime = false;
  bool stime_written = false;  // an stime(...) was written, valid or not (no "no stime" note then)
  double stime = 0;
  SourcePos stime_pos;
  bool has_end = false;
};

}  // namespace rtplc::lang
