// Structured Text (IEC 61131-3) as found in PLCopen bodies: lexer and parser to
// a small tree (docs/plcopen.md, "ST"). Expressions with IEC precedence,
// assignments, IF/ELSIF/ELSE, CASE, FOR, RETURN, EXIT and CONTINUE, function
// and FB calls (formal and informal), WHILE and REPEAT, labels and JMP (as
// CODESYS writes them; IEC 61131-3 and MatIEC have jumps in IL only). Positions are file positions: the text sits in
// an XML element, and `origin` maps its offsets back to the file.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "common/xml_reader.h"
#include "lang/plcopen/emitter.h"

namespace rtplc::lang::plcopen {

struct Expr {
  enum class Kind : uint8_t { kLiteral, kName, kNot, kNeg, kBinary, kCall };
  Kind kind = Kind::kLiteral;
  SourcePos pos;
  double k = 0;
  bool is_bool = false, is_time = false, is_real = false;
  bool is_string = false;  // kLiteral: a STRING, its bytes in `text`
  bool wide = false;       // ... a WSTRING, its UTF-16 code units as UTF-8 in `text`
  // kLiteral: T#... is a TIME, D#, TOD#, DT# their types (what TO_DINT converts from).
  std::optional<iec::IecType> time_type;
  std::string text;
  // kName: "a", "fb1.Q", "p.x", or with array indices "a[#1]", "m[#2].x":
  // `[#n]` stands for the next n expressions of `args`, in order.
  std::string name;  // kCall: the function
  BinOp op = BinOp::kAdd;
  std::vector<std::unique_ptr<Expr>> args;
  std::vector<std::string> arg_names;  // formal names ("" when informal), per arg
  bool en_guarded = false;  // kCall: the function of an `f(EN := c, ...)`, which SEL(c, 0, f) wraps
};

struct CallArg {
  std::string formal;  // "" for an informal argument
  bool output = false; // `Q => x`
  std::unique_ptr<Expr> value;  // input
  std::string target;           // output: the variable written (a path as Expr::name)
  std::vector<std::unique_ptr<Expr>> target_index;  // its `[#n]` indices
  SourcePos pos;
};

struct Stmt;
using Block = std::vector<std::unique_ptr<Stmt>>;

struct CaseBranch {
  std::vector<std::pair<std::unique_ptr<Expr>, std::unique_ptr<Expr>>> labels;  // lo, hi (hi null)
  Block body;
};

struct Stmt {
  enum class Kind : uint8_t {
    kAssign, kIf, kCase, kFor, kCall, kReturn, kExit, kContinue, kWhile, kRepeat,
    kLabel,  // `name:` before a statement: target = the label, upper-case
    kJump,   // JMP name: target = the label, upper-case
  };
  Kind kind = Kind::kAssign;
  SourcePos pos;
  std::string target;                // assign: variable path; for: loop variable; call: instance
  std::vector<std::unique_ptr<Expr>> target_index;  // the path's `[#n]` indices (Expr::name)
  std::unique_ptr<Expr> value;       // assign: value; case: selector; while: condition; repeat: UNTIL's
  std::vector<std::pair<std::unique_ptr<Expr>, Block>> branches;  // if / elsif
  Block else_body;
  bool has_else = false;
  std::vector<CaseBranch> cases;
  std::unique_ptr<Expr> from, to, by;  // for
  Block body;                          // for, while, repeat
  std::vector<CallArg> call_args;      // call
  bool en_gated = false;               // call: its EN made it the body of an IF (`IF en THEN call`)
  // assign: `inst.ENO := EN` the parser wrote for a call with EN (or TRUE after
  // one without); nothing when `inst` is a function, not an instance.
  bool eno_of_call = false;
};

// Parses an ST statement list. `origin` is the element holding the text (for
// file positions); `base` is added to offsets (0 for a whole body).
Block parse_st(std::string_view text, const XmlElement& origin, DiagnosticList& diags);

// Parses one expression (an FBD variable's <expression>, an SFC condition).
// `begin`/`end` select part of `text` (an IL operand); positions stay those of
// the whole text.
std::unique_ptr<Expr> parse_st_expression(std::string_view text, const XmlElement& origin,
                                          DiagnosticList& diags, size_t begin = 0,
                                          size_t end = std::string_view::npos);
// Statements in text[begin, end) (an IL CAL's call), positions as above.
Block parse_st_range(std::string_view text, size_t begin, size_t end, const XmlElement& origin,
                     DiagnosticList& diags);

// The `}` closing the pragma that opens at `open` (a `{`), braces nested inside
// it counted (Beremiz's `{{ C code }}`); npos when it never closes.
size_t pragma_close(std::string_view text, size_t open);
// The closing quote of the string literal that opens at `open` (`'` or `"`):
// a `$` escapes the character after it (`$'`, `$$`). npos when it never closes.
size_t string_close(std::string_view text, size_t open);

// Names an ST text assigns (`x :=`, `=> x`), upper-cased, for the importer's
// "written anywhere" pre-pass.
void st_written_names(std::string_view text, std::vector<std::string>& out);

}  // namespace rtplc::lang::plcopen
