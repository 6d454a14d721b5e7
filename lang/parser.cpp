// Recursive-descent parser for the control algorithm file (spec fbd-language.md):
//
//   file      := decl* '%%' stmt* 'END' ['%%'] macrodef* EOF
//   decl      := 'MACRO' NAME '(' INT sep INT sep INT ')'        sep := ':' | '|'
//   stmt      := 'stime' '(' NUMBER ')' | REF '=' rhs | NAME '(' args ')'
//   rhs       := NAME '(' args ')' | 'MACRO' NAME '(' args ')'
//   args      := [ arg { ',' arg } ]
//   arg       := REF | ['-'|'+'] NUMBER | DEVICE | STRING
//   macrodef  := 'MACRO' NAME '(' [ REF { ',' REF } ] ')' '{' stmt* 'RETURN' '(' REF ')' '}'
//
// The seed's own examples omit the second '%%' (accepted) and spell the
// derivative both `derv` and `deriv` (the registry accepts both).
#include "lang/parser.h"

#include <cmath>
#include <string>

namespace rtplc::lang {
namespace {

class Parser {
 public:
  Parser(const std::vector<Token>& toks, DiagnosticList& d) : t_(toks), diags_(d) {}

  // file := decl* '%%' stmt* 'END' ['%%'] macrodef* EOF
  Program file() {
    Program prog;
    while (is(Tok::kMacro) && !looks_like_definition()) decl(prog);
    if (is(Tok::kSections)) {
      next();
    } else {
      error_here("expected '%%' to start the program body (after any MACRO declarations)");
      // Carry on as if it were there: most likely the file simply starts with the body.
    }
    body(prog);
    if (is(Tok::kEnd)) {
      prog.has_end = true;
      next();
    } else {
      error_here("missing END: the program body must end with a line holding END");
    }
    if (is(Tok::kSections)) next();
    while (is(Tok::kMacro)) macrodef(prog);
    if (!is(Tok::kEof)) {
      error_here(std::string("unexpected ") + describe(cur()) +
                 " after the macro definitions: expected 'MACRO NAME(...) { ... }' or the end "
                 "of the file");
    }
    return prog;
  }

 private:
  // ---- token helpers ----
  const Token& cur() const { return t_[i_]; }
  const Token& peek(size_t k) const { return t_[std::min(i_ + k, t_.size() - 1)]; }
  bool is(Tok k) const { return cur().kind == k; }
  void next() {
    if (i_ + 1 < t_.size()) ++i_;
  }
  static std::string describe(const Token& t) {
    if (t.kind == Tok::kEof) return "end of file";
    return "'" + std::string(t.text) + "'";
  }
  void error_at(const Token& t, const std::string& msg) { diags_.error(t.pos, msg, t.length); }
  void error_here(const std::string& msg) { error_at(cur(), msg); }
  bool expect(Tok k, const char* context) {
    if (is(k)) {
      next();
      return true;
    }
    error_here(std::string("expected ") + tok_name(k) + " " + context + ", found " +
               describe(cur()));
    return false;
  }
  // Skips the rest of the statement that started on `line`: statements are one
  // per line in every file the seed's editor wrote.
  void sync_after(uint32_t line) {
    while (!is(Tok::kEof) && cur().pos.line <= line) {
      if (is(Tok::kRBrace) || is(Tok::kSections)) return;
      next();
    }
  }
  // sync_after, but if nothing was consumed and we still sit on the failing
  // statement's line (at a '}' or '%%' there), step over one token so no loop can
  // stall. A token on a later line is the next statement's start: keep it.
  void recover(uint32_t line) {
    const size_t before = i_;
    sync_after(line);
    if (i_ == before && cur().pos.line <= line) next();
  }
  // 'MACRO NAME (' followed by a block id or ')' starts a definition; followed
  // by a number it is a declaration.
  bool looks_like_definition() const {
    return peek(1).kind == Tok::kIdent && peek(2).kind == Tok::kLParen &&
           (peek(3).kind == Tok::kRef || peek(3).kind == Tok::kRParen);
  }

  // decl := 'MACRO' NAME '(' INT sep INT sep INT ')'
  void decl(Program& prog) {
    const uint32_t line = cur().pos.line;
    next();  // MACRO
    MacroDecl d;
    if (!is(Tok::kIdent)) {
      error_here("expected a macro name after MACRO, found " + describe(cur()));
      recover(line);
      return;
    }
    d.name = std::string(cur().text);
    d.pos = cur().pos;
    d.name_length = cur().length;
    next();
    uint32_t counts[3] = {0, 0, 0};
    bool ok = expect(Tok::kLParen, "after the macro name (as in MACRO PID(2:0:3))");
    for (int k = 0; ok && k < 3; ++k) {
      if (k > 0) {
        if (is(Tok::kColon) || is(Tok::kBar)) {
          next();
        } else {
          error_here("expected ':' or '|' between the counts of MACRO " + d.name +
                     " (analog inputs : digital inputs : parameters)");
          ok = false;
          break;
        }
      }
      if (!is(Tok::kNumber) || cur().value != std::floor(cur().value) || cur().value < 0 ||
          cur().value > 1000) {
        error_here("expected a whole number of " +
                   std::string(k == 0 ? "analog inputs" : k == 1 ? "digital inputs" : "parameters") +
                   " in MACRO " + d.name + "(l:m:n)");
        ok = false;
        break;
      }
      counts[k] = static_cast<uint32_t>(cur().value);
      next();
    }
    if (ok) ok = expect(Tok::kRParen, "to close the macro declaration");
    if (!ok) {
      recover(line);
      return;
    }
    d.n_analog = counts[0];
    d.n_digital = counts[1];
    d.n_params = counts[2];
    prog.decls.push_back(d);
  }

  // Body statements until END, EOF, or something that cannot start a statement.
  void body(Program& prog) {
    while (!is(Tok::kEof) && !is(Tok::kEnd)) {
      if (is(Tok::kSections) || (is(Tok::kMacro) && looks_like_definition())) return;
      statement(prog, &prog.body, /*in_macro=*/false);
    }
  }

  // stmt := 'stime' '(' NUMBER ')' | REF '=' rhs | NAME '(' args ')'
  void statement(Program& prog, std::vector<Call>* out, bool in_macro) {
    const Token& start = cur();
    const uint32_t line = start.pos.line;
    if (is(Tok::kIdent) && start.text == "stime") {
      stime(prog, in_macro);
      return;
    }
    Call call;
    call.pos = start.pos;
    if (is(Tok::kRef)) {
      call.has_target = true;
      call.target = ref_of(cur());
      next();
      if (!expect(Tok::kEquals, "after the block id (as in F1 = add(F2, F3))")) {
        recover(line);
        return;
      }
      if (is(Tok::kMacro)) {
        call.is_macro = true;
        next();
      }
    } else if (is(Tok::kMacro)) {
      error_here("a macro call needs a block id to hold its result, as in F20 = MACRO " +
                 std::string(peek(1).kind == Tok::kIdent ? peek(1).text : "NAME") + "(...)");
      recover(line);
      return;
    } else if (!is(Tok::kIdent)) {
      if (in_macro && (is(Tok::kRBrace) || is(Tok::kReturn))) return;  // caller's business
      if (is(Tok::kReturn)) {
        error_here("RETURN is only allowed at the end of a macro definition");
      } else {
        error_here("expected a statement (ID = block(...), an output block, or stime(...)), "
                   "found " + describe(cur()));
      }
      recover(line);
      return;
    }
    if (!is(Tok::kIdent)) {
      error_here(std::string("expected a block name") + (call.is_macro ? " (the macro's name)" : "") +
                 ", found " + describe(cur()));
      recover(line);
      return;
    }
    call.name = std::string(cur().text);
    call.name_pos = cur().pos;
    call.name_length = cur().length;
    next();
    const Token& lparen = cur();
    if (!expect(Tok::kLParen, ("after '" + call.name + "'").c_str()) || !args(call, lparen)) {
      recover(line);
      return;
    }
    out->push_back(std::move(call));
  }

  // 'stime' '(' NUMBER ')'
  void stime(Program& prog, bool in_macro) {
    const Token& kw = cur();
    const uint32_t line = kw.pos.line;
    if (!in_macro) prog.stime_written = true;
    next();
    if (!expect(Tok::kLParen, "after stime")) {
      recover(line);
      return;
    }
    if (!is(Tok::kNumber)) {
      error_here("expected the sampling period in seconds, as in stime(0.1)");
      recover(line);
      return;
    }
    const Token& num = cur();
    double v = num.value;
    next();
    if (!expect(Tok::kRParen, "to close stime(...)")) {
      recover(line);
      return;
    }
    if (in_macro) {
      error_at(kw, "stime belongs to the program body, not to a macro definition");
    } else if (prog.has_stime) {
      error_at(kw, "stime is set twice (first at line " + std::to_string(prog.stime_pos.line) + ")");
    } else if (!(v >= 1e-4 && v <= 3600)) {
      error_at(num, "sampling period must be between 0.0001 s and 3600 s");
    } else {
      prog.has_stime = true;
      prog.stime = v;
      prog.stime_pos = kw.pos;
    }
  }

  // A token that clearly starts the next statement: 'F7 =', 'dao(', END, %%, MACRO.
  bool at_statement_start() const {
    return (is(Tok::kRef) && peek(1).kind == Tok::kEquals) ||
           (is(Tok::kIdent) && peek(1).kind == Tok::kLParen) || is(Tok::kEnd) ||
           is(Tok::kSections) || is(Tok::kMacro) || is(Tok::kReturn) || is(Tok::kRBrace);
  }

  // args := [ arg { ',' arg } ] ')'
  // An argument list may span lines, but one that runs into the next statement was
  // left open: say so at its '(' and leave that statement intact.
  bool args(Call& call, const Token& lparen) {
    if (is(Tok::kRParen)) {
      next();
      return true;
    }
    for (;;) {
      if (cur().pos.line > lparen.pos.line && at_statement_start()) {
        error_at(lparen, "'(' of '" + call.name + "' is not closed: expected ')' before line " +
                             std::to_string(cur().pos.line));
        return false;
      }
      Arg a;
      if (!arg(a)) return false;
      call.args.push_back(std::move(a));
      if (is(Tok::kComma)) {
        next();
        continue;
      }
      if (is(Tok::kRParen)) {
        next();
        return true;
      }
      if (cur().pos.line > lparen.pos.line && at_statement_start()) {
        error_at(lparen, "'(' of '" + call.name + "' is not closed: expected ')' before line " +
                             std::to_string(cur().pos.line));
        return false;
      }
      error_here("expected ',' or ')' in the arguments of '" + call.name + "', found " +
                 describe(cur()));
      return false;
    }
  }

  // arg := REF | ['-'|'+'] NUMBER | DEVICE | STRING
  bool arg(Arg& a) {
    const Token& t = cur();
    a.pos = t.pos;
    a.length = t.length;
    switch (t.kind) {
      case Tok::kRef:
        a.kind = Arg::Kind::kRef;
        a.ref = ref_of(t);
        next();
        return true;
      case Tok::kMinus:
      case Tok::kPlus: {
        const bool neg = t.kind == Tok::kMinus;
        next();
        if (!is(Tok::kNumber)) {
          error_here(is(Tok::kRef) ? "a block input cannot be negated here; use sub() or scale()"
                                   : "expected a number after the sign");
          return false;
        }
        a.kind = Arg::Kind::kNumber;
        a.number = neg ? -cur().value : cur().value;
        a.length = cur().pos.col + cur().length - t.pos.col;
        next();
        return true;
      }
      case Tok::kNumber:
        a.kind = Arg::Kind::kNumber;
        a.number = t.value;
        next();
        return true;
      case Tok::kDevice:
        a.kind = Arg::Kind::kDevice;
        a.device = t.letter;
        a.device_no = t.number;
        if (t.number_overflow) {
          error_at(t, "device number too large");
          return false;
        }
        next();
        return true;
      case Tok::kString:
        a.kind = Arg::Kind::kString;
        a.text = std::string(t.text.substr(1, t.text.size() - 2));
        next();
        return true;
      default:
        error_here("expected an argument (a block id like F1, a number, a device address like "
                   "p0/d1/c2, or a \"label\"), found " + describe(t));
        return false;
    }
  }

  // macrodef := 'MACRO' NAME '(' [ REF { ',' REF } ] ')' '{' stmt* 'RETURN' '(' REF ')' '}'
  void macrodef(Program& prog) {
    const uint32_t line = cur().pos.line;
    next();  // MACRO
    MacroDef def;
    if (!is(Tok::kIdent)) {
      error_here("expected a macro name after MACRO, found " + describe(cur()));
      skip_macro_body(line);
      return;
    }
    def.name = std::string(cur().text);
    def.pos = cur().pos;
    def.name_length = cur().length;
    next();
    if (!expect(Tok::kLParen, "after the macro name")) {
      skip_macro_body(line);
      return;
    }
    if (!is(Tok::kRParen)) {
      for (;;) {
        if (!is(Tok::kRef)) {
          error_here("expected a formal like M1, N1 or P1 in the definition of MACRO " + def.name +
                     ", found " + describe(cur()));
          skip_macro_body(line);
          return;
        }
        def.formals.push_back(ref_of(cur()));
        next();
        if (is(Tok::kComma)) {
          next();
          continue;
        }
        break;
      }
    }
    if (!expect(Tok::kRParen, "to close the formal list") ||
        !expect(Tok::kLBrace, ("to open the body of MACRO " + def.name).c_str())) {
      skip_macro_body(line);
      return;
    }
    Program scratch;  // a stime inside a macro is reported by statement()
    while (!is(Tok::kEof) && !is(Tok::kRBrace) && !is(Tok::kReturn)) {
      if (is(Tok::kMacro) && looks_like_definition()) break;  // missing '}' before next def
      statement(scratch, &def.body, /*in_macro=*/true);
    }
    if (is(Tok::kReturn)) {
      const uint32_t rline = cur().pos.line;
      next();
      if (expect(Tok::kLParen, "after RETURN")) {
        if (is(Tok::kRef)) {
          def.has_return = true;
          def.ret = ref_of(cur());
          next();
          expect(Tok::kRParen, "to close RETURN(...)");
        } else {
          error_here("RETURN needs the id of the block whose output the macro returns, as in "
                     "RETURN(M7)");
          recover(rline);
        }
      } else {
        recover(rline);
      }
      while (!is(Tok::kEof) && !is(Tok::kRBrace) && !(is(Tok::kMacro) && looks_like_definition())) {
        error_here("statement after RETURN: RETURN must be the last line of a macro");
        recover(cur().pos.line);
      }
    }
    def.close_pos = cur().pos;
    if (is(Tok::kRBrace)) {
      next();
    } else {
      error_here("expected '}' to close MACRO " + def.name + ", found " + describe(cur()));
    }
    prog.defs.push_back(std::move(def));
  }

  void skip_macro_body(uint32_t line) {
    sync_after(line);
    int depth = 0;
    while (!is(Tok::kEof)) {
      if (is(Tok::kLBrace)) ++depth;
      if (is(Tok::kRBrace)) {
        next();
        if (--depth <= 0) return;
        continue;
      }
      if (depth == 0 && is(Tok::kMacro)) return;
      next();
    }
  }

  Ref ref_of(const Token& t) {
    Ref r;
    r.letter = t.letter;
    r.number = t.number;
    r.pos = t.pos;
    r.length = t.length;
    if (t.number_overflow) error_at(t, "block id number too large");
    return r;
  }

  const std::vector<Token>& t_;
  DiagnosticList& diags_;
  size_t i_ = 0;
};

}  // namespace

Program parse(const std::vector<Token>& tokens, DiagnosticList& diags) {
  return Parser(tokens, diags).file();
}

}  // namespace rtplc::lang
