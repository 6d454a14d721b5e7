// ST lexer and recursive-descent parser (see st.h). Each parse function sits
// under its grammar rule; precedence from IEC 61131-3 table 71, loosest first:
// OR, XOR, AND/&, = <>, < > <= >=, + -, * / MOD, **, unary - NOT, primary.
#include "lang/plcopen/st.h"

#include <algorithm>
#include <cctype>
#include <optional>
#include <set>
#include <string>

#include "lang/plcopen/project.h"

namespace rtplc::lang::plcopen {
namespace {

struct Tok {
  enum class T : uint8_t { kIdent, kNumber, kOp, kString, kEnd };
  T t = T::kEnd;
  std::string text;  // identifiers upper-cased in `up`
  std::string up;
  size_t offset = 0;
  SourcePos pos;
};

// Offsets -> file positions, for monotonic queries (one pass over the text).
class PosMap {
 public:
  PosMap(std::string_view text, const XmlElement& e) : s_(text), e_(e) {
    cur_ = e.text_anchors.empty() ? e.pos : e.text_anchors[0].pos;
  }
  SourcePos at(size_t off) {
    while (a_ + 1 < e_.text_anchors.size() && e_.text_anchors[a_ + 1].offset <= off) {
      ++a_;
      i_ = e_.text_anchors[a_].offset;
      cur_ = e_.text_anchors[a_].pos;
    }
    for (; i_ < off && i_ < s_.size(); ++i_) {
      if (s_[i_] == '\n') {
        ++cur_.line;
        cur_.col = 1;
      } else if ((static_cast<unsigned char>(s_[i_]) & 0xC0) != 0x80) {
        ++cur_.col;
      }
    }
    return cur_;
  }

 private:
  std::string_view s_;
  const XmlElement& e_;
  size_t a_ = 0, i_ = 0;
  SourcePos cur_;
};

bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }

// Tokens of s[begin, s.size()); positions count from the start of `s`.
std::vector<Tok> lex(std::string_view s, const XmlElement& origin, DiagnosticList& d, size_t begin = 0) {
  std::vector<Tok> out;
  PosMap pm(s, origin);
  size_t i = begin;
  while (i < s.size()) {
    const char c = s[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
      continue;
    }
    if (s.substr(i, 2) == "(*" || s.substr(i, 2) == "/*") {
      const char* close = s[i] == '(' ? "*)" : "*/";
      const size_t e = s.find(close, i + 2);
      if (e == std::string_view::npos) {
        d.error(pm.at(i), "unterminated comment");
        break;
      }
      i = e + 2;
      continue;
    }
    if (s.substr(i, 2) == "//") {
      while (i < s.size() && s[i] != '\n') ++i;
      continue;
    }
    if (c == '{') {
      // A pragma ({attribute 'hide'}, CODESYS; {info ...}): the standard lets
      // an implementation ignore those it does not know, and rtplc knows none.
      const size_t e = pragma_close(s, i);
      if (e == std::string_view::npos) {
        d.error(pm.at(i), "unterminated pragma '{'");
        break;
      }
      i = e + 1;
      continue;
    }
    Tok t;
    t.offset = i;
    t.pos = pm.at(i);
    const size_t b = i;
    size_t blanks_from = 0, blanks_to = 0;  // blanks inside a duration literal
    if (c == '%' && i + 1 < s.size() && std::isalpha(static_cast<unsigned char>(s[i + 1]))) {
      // A directly represented variable: %IX0.0, %QW3, %MD10.
      ++i;
      while (i < s.size() && (ident_char(s[i]) || (s[i] == '.' && i + 1 < s.size() &&
                                                   std::isdigit(static_cast<unsigned char>(s[i + 1])))))
        ++i;
      t.t = Tok::T::kIdent;
    } else if (ident_start(c)) {
      while (i < s.size() && ident_char(s[i])) ++i;
      if (i < s.size() && s[i] == '#') {  // T#1s, INT#5, BOOL#TRUE, WORD#16#F0F0
        // D#2024-01-15, TOD#12:30:15, DT#2024-01-15-12:30:15: '-' and ':' belong to the literal.
        const bool date = date_literal_type(s.substr(b, i - b)).has_value();
        const std::string prefix = upper(s.substr(b, i - b));
        ++i;
        if ((prefix == "STRING" || prefix == "WSTRING") && i < s.size() && (s[i] == '\'' || s[i] == '"')) {
          // STRING#'text': a typed string literal, read as one.
          const size_t e = string_close(s, i);
          i = e == std::string_view::npos ? s.size() : e + 1;
          t.t = Tok::T::kString;
          t.text.assign(s.substr(b, i - b));
          t.up = upper(t.text);
          out.push_back(std::move(t));
          continue;
        }
        // `T# 30000ms`, as OpenPLC Editor writes some durations: the blanks
        // after a duration's '#' are no part of it (dropped from the text below).
        if (prefix == "T" || prefix == "TIME") {
          size_t k = i;
          while (k < s.size() && (s[k] == ' ' || s[k] == '\t')) ++k;
          if (k > i && k < s.size() && (std::isdigit(static_cast<unsigned char>(s[k])) || s[k] == '-')) {
            blanks_from = i;
            blanks_to = k;
            i = k;
          }
        }
        while (i < s.size() && (ident_char(s[i]) || s[i] == '.' || s[i] == '-' || s[i] == '+' || s[i] == '#' ||
                                (date && s[i] == ':'))) {
          if ((s[i] == '-' || s[i] == '+') && !date && !(s[i - 1] == 'e' || s[i - 1] == 'E' || s[i - 1] == '#'))
            break;
          ++i;
        }
        t.t = Tok::T::kNumber;
      } else {
        t.t = Tok::T::kIdent;
      }
    } else if (std::isdigit(static_cast<unsigned char>(c))) {
      while (i < s.size() && (ident_char(s[i]) || s[i] == '#' || s[i] == '.')) {
        if (s[i] == '.' && i + 1 < s.size() && s[i + 1] == '.') break;  // 1..5
        if ((s[i] == 'e' || s[i] == 'E') && i + 1 < s.size() && (s[i + 1] == '-' || s[i + 1] == '+'))
          ++i;
        ++i;
      }
      t.t = Tok::T::kNumber;
    } else if (c == '\'' || c == '"') {
      // Up to the closing quote; `$'` (`$"`) and `$$` do not close it.
      const size_t e = string_close(s, i);
      i = e == std::string_view::npos ? s.size() : e + 1;
      t.t = Tok::T::kString;
    } else {
      static const char* const two[] = {":=", "=>", "<=", ">=", "<>", "**", ".."};
      t.t = Tok::T::kOp;
      i += 1;
      for (const char* op : two) {
        if (s.substr(b, 2) == op) i = b + 2;
      }
    }
    t.text.assign(s.substr(b, i - b));
    if (blanks_to > blanks_from) t.text.erase(blanks_from - b, blanks_to - blanks_from);
    t.up = upper(t.text);
    out.push_back(std::move(t));
  }
  Tok end;
  end.offset = s.size();
  end.pos = pm.at(s.size());
  out.push_back(end);
  return out;
}

class Parser {
 public:
  Parser(std::vector<Tok> toks, DiagnosticList& d) : t_(std::move(toks)), d_(d) {}

  // statement_list ::= { statement ';' }
  Block statements(std::initializer_list<const char*> enders) {
    Block out;
    while (!failed_ && !at_end()) {
      for (const char* e : enders) {
        if (peek().t == Tok::T::kIdent && peek().up == e) return out;
      }
      if (accept_op(";")) continue;
      if (peek().t == Tok::T::kIdent && peek(1).t == Tok::T::kOp && peek(1).text == ":") {
        // `name:` labels the statement that follows (or the end of the list).
        auto l = std::make_unique<Stmt>();
        l->kind = Stmt::Kind::kLabel;
        l->pos = peek().pos;
        l->target = next().up;
        ++i_;
        out.push_back(std::move(l));
        continue;
      }
      const size_t pending = pending_eno_.size();
      auto s = statement();
      if (failed_) break;
      // `ENO => ok` of the calls in this statement: ok := EN, put before it, so
      // EN is read as the call reads it (the statement changes nothing before
      // its calls run) and the statement's own code already sees ok.
      while (pending_eno_.size() > pending) {
        out.push_back(std::move(pending_eno_[pending]));
        pending_eno_.erase(pending_eno_.begin() + static_cast<std::ptrdiff_t>(pending));
      }
      if (s) out.push_back(std::move(s));
      if (!at_end() && !(peek().t == Tok::T::kOp && peek().text == ";")) {
        bool ender = false;
        for (const char* e : enders) ender = ender || (peek().t == Tok::T::kIdent && peek().up == e);
        if (!ender) {
          error(peek().pos, "expected ';' after the statement, found '" + peek().text + "'");
          break;
        }
      }
    }
    return out;
  }

  std::unique_ptr<Expr> whole_expression() {
    auto e = expression();
    if (!failed_ && !at_end()) error(peek().pos, "unexpected '" + peek().text + "' after the expression");
    // An expression alone (an FBD variable, an SFC condition) has no statement to
    // put `ok := EN` after.
    if (!failed_ && !pending_eno_.empty()) {
      error(pending_eno_.front()->pos, "ENO => is allowed in a statement's calls only, not in an expression alone");
    }
    return e;
  }

  bool at_end() const { return t_[i_].t == Tok::T::kEnd; }
  bool failed() const { return failed_; }

  // `inst.ENO` (OpenPLC Editor: `TOF0(EN := TON0.ENO, ...)`) is the lowering's
  // (Lowering::eno_var: TRUE until a call with EN writes its EN). A call
  // without EN of an instance that some call in this body gives EN sets it
  // TRUE again, as MatIEC's does.
  void resolve_eno(Block& b) {
    for (size_t k = 0; k < b.size(); ++k) {
      // A call without EN of an instance some other call gives EN: its ENO is TRUE again.
      Stmt& c = *b[k];
      if (c.kind == Stmt::Kind::kCall && !c.en_gated && en_called_.count(upper(c.target))) {
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(k) + 1,
                 assignment(c.target + ".ENO", c.target_index, literal(1, true, c.pos), c.pos, true));
        ++k;
      }
    }
    for (auto& st : b) {
      for (auto& [c, body] : st->branches) resolve_eno(body);
      for (CaseBranch& cb : st->cases) resolve_eno(cb.body);
      resolve_eno(st->else_body);
      resolve_eno(st->body);
    }
  }

 private:
  const Tok& peek(size_t k = 0) const { return t_[i_ + k < t_.size() ? i_ + k : t_.size() - 1]; }
  const Tok& next() { return t_[i_ < t_.size() - 1 ? i_++ : i_]; }
  void error(SourcePos p, const std::string& m) {
    if (!failed_) d_.error(p, m);
    failed_ = true;
  }
  bool is_kw(const char* k) const { return peek().t == Tok::T::kIdent && peek().up == k; }
  bool accept_kw(const char* k) {
    if (!is_kw(k)) return false;
    ++i_;
    return true;
  }
  bool accept_op(const char* o) {
    if (peek().t != Tok::T::kOp || peek().text != o) return false;
    ++i_;
    return true;
  }
  void expect_kw(const char* k, const char* where) {
    if (!accept_kw(k))
      error(peek().pos, std::string("expected ") + k + " " + where + ", found '" + peek().text + "'");
  }
  void expect_op(const char* o, const char* where) {
    if (!accept_op(o))
      error(peek().pos, std::string("expected '") + o + "' " + where + ", found '" + peek().text + "'");
  }

  // variable ::= ident [ '[' expr { ',' expr } ']' ] { '.' ident [ '[' ... ']' ] }
  // Indices go to `index`; the path marks each group as `[#n]`.
  std::string variable_path(std::vector<std::unique_ptr<Expr>>& index) {
    std::string p = next().text;
    for (;;) {
      if (accept_op("[")) {
        size_t n = 0;
        do {
          auto e = expression();
          if (failed_) return p;
          index.push_back(std::move(e));
          ++n;
        } while (accept_op(","));
        expect_op("]", "to close the array index");
        if (failed_) return p;
        p += "[#" + std::to_string(n) + "]";
        continue;
      }
      if (peek().t == Tok::T::kOp && peek().text == "." && peek(1).t == Tok::T::kIdent) {
        ++i_;
        p += "." + next().text;
        continue;
      }
      return p;
    }
  }

  // statement ::= assignment | fb_call | if | case | for | RETURN | EXIT | CONTINUE
  //               | while | repeat | JMP label   (a label `name:` is taken by statements())
  std::unique_ptr<Stmt> statement() {
    const Tok& t = peek();
    if (t.t != Tok::T::kIdent) {
      error(t.pos, "expected a statement, found '" + t.text + "'");
      return nullptr;
    }
    if (t.up == "RETURN" || t.up == "EXIT" || t.up == "CONTINUE") {
      if (t.up != "RETURN" && loops_ == 0) {
        error(t.pos, t.up + " outside a loop (FOR, WHILE, REPEAT)");
        return nullptr;
      }
      auto s = std::make_unique<Stmt>();
      s->kind = t.up == "RETURN" ? Stmt::Kind::kReturn : t.up == "EXIT" ? Stmt::Kind::kExit : Stmt::Kind::kContinue;
      s->pos = next().pos;
      return s;
    }
    if ((t.up == "INITIAL_STEP" || t.up == "STEP" || t.up == "ACTION") && peek(1).t == Tok::T::kIdent &&
        peek(2).t == Tok::T::kOp && peek(2).text == ":") {
      error(t.pos, t.up + " " + peek(1).text + ": a textual SFC (INITIAL_STEP, STEP, TRANSITION, ACTION) is a "
                   "POU's whole body, with no statements before it (docs/st.md, \"Textual SFC\")");
      return nullptr;
    }
    if (t.up == "TRANSITION" && peek(1).t == Tok::T::kIdent && (peek(1).up == "FROM" || peek(2).up == "FROM")) {
      error(t.pos, "TRANSITION: a textual SFC (INITIAL_STEP, STEP, TRANSITION, ACTION) is a POU's whole body, "
                   "with no statements before it (docs/st.md, \"Textual SFC\")");
      return nullptr;
    }
    if (t.up == "GOTO") {
      error(t.pos, "GOTO is not ST: a jump is JMP label");
      return nullptr;
    }
    if (t.up == "JMP" && peek(1).t == Tok::T::kIdent) {
      auto s = std::make_unique<Stmt>();
      s->kind = Stmt::Kind::kJump;
      s->pos = next().pos;
      s->target = next().up;
      return s;
    }
    if (t.up == "JMP") {
      error(peek(1).pos, "expected a label after JMP, found '" + peek(1).text + "'");
      return nullptr;
    }
    if (t.up == "IF" || t.up == "CASE" || t.up == "FOR" || t.up == "WHILE" || t.up == "REPEAT") {
      if (++nesting_ > 100) {
        error(t.pos, "statements nested deeper than 100");
        return nullptr;
      }
      auto r = t.up == "IF"      ? if_statement()
               : t.up == "CASE"  ? case_statement()
               : t.up == "FOR"   ? for_statement()
               : t.up == "WHILE" ? while_statement()
                                 : repeat_statement();
      --nesting_;
      return r;
    }
    auto s = std::make_unique<Stmt>();
    s->pos = t.pos;
    s->target = variable_path(s->target_index);
    if (failed_) return nullptr;
    if (accept_op(":=")) {
      s->kind = Stmt::Kind::kAssign;
      s->value = expression();
      return s;
    }
    if (peek().t == Tok::T::kOp && peek().text == "(") {
      s->kind = Stmt::Kind::kCall;
      ++i_;
      call_arguments(s->call_args);
      if (failed_) return nullptr;
      // EN: the call happens only when it holds, EN read once:
      //   IF en THEN [ok := TRUE;] inst.ENO := TRUE; call
      //   ELSE [ok := FALSE;] inst.ENO := FALSE; END_IF
      // (`ok` for `ENO => ok`; inst.ENO is the lowering's, nothing when the
      // target is a function; resolve_eno sets it TRUE after a call of the
      // same instance without EN).
      std::optional<CallArg> eno;
      std::unique_ptr<Expr> en = take_en_eno(s->call_args, s->pos, &eno);
      if (failed_ || !en) return s;
      en_called_.insert(upper(s->target));
      s->en_gated = true;
      auto w = std::make_unique<Stmt>();
      w->kind = Stmt::Kind::kIf;
      w->pos = s->pos;
      w->has_else = true;
      Block body;
      for (bool taken : {true, false}) {
        Block& into = taken ? body : w->else_body;
        const double k = taken ? 1 : 0;
        if (eno) into.push_back(assignment(eno->target, eno->target_index, literal(k, true, s->pos), s->pos, false));
        into.push_back(assignment(s->target + ".ENO", s->target_index, literal(k, true, s->pos), s->pos, true));
      }
      body.push_back(std::move(s));
      w->branches.emplace_back(std::move(en), std::move(body));
      return w;
    }
    error(peek().pos, "expected ':=' or '(' after '" + s->target + "', found '" + peek().text + "'");
    return nullptr;
  }

  // call_args ::= [ arg { ',' arg } ] ')' ;  arg ::= [ident ':='] expr | ident '=>' variable
  void call_arguments(std::vector<CallArg>& out) {
    if (accept_op(")")) return;
    for (;;) {
      CallArg a;
      a.pos = peek().pos;
      if (peek().t == Tok::T::kIdent && peek(1).t == Tok::T::kOp &&
          (peek(1).text == ":=" || peek(1).text == "=>")) {
        a.formal = next().text;
        if (next().text == "=>") {
          a.output = true;
          if (peek().t != Tok::T::kIdent) {
            error(peek().pos, "expected a variable after '=>'");
            return;
          }
          a.target = variable_path(a.target_index);
        }
      } else if (is_kw("NOT") && peek(1).t == Tok::T::kIdent && peek(2).t == Tok::T::kOp &&
                 peek(2).text == "=>") {
        error(peek().pos, "negated output assignment (NOT x =>) is not supported");
        return;
      }
      if (!a.output) a.value = expression();
      if (failed_) return;
      out.push_back(std::move(a));
      if (accept_op(")")) return;
      expect_op(",", "between arguments");
      if (failed_) return;
    }
  }

  // if ::= IF expr THEN stmts { ELSIF expr THEN stmts } [ ELSE stmts ] END_IF
  std::unique_ptr<Stmt> if_statement() {
    auto s = std::make_unique<Stmt>();
    s->kind = Stmt::Kind::kIf;
    s->pos = next().pos;
    for (;;) {
      auto cond = expression();
      expect_kw("THEN", "after the IF condition");
      if (failed_) return nullptr;
      Block body = statements({"ELSIF", "ELSE", "END_IF"});
      s->branches.emplace_back(std::move(cond), std::move(body));
      if (failed_) return nullptr;
      if (!accept_kw("ELSIF")) break;
    }
    if (accept_kw("ELSE")) {
      s->has_else = true;
      s->else_body = statements({"END_IF"});
    }
    expect_kw("END_IF", "to close IF");
    return failed_ ? nullptr : std::move(s);
  }

  // case ::= CASE expr OF { labels ':' stmts } [ ELSE stmts ] END_CASE
  std::unique_ptr<Stmt> case_statement() {
    auto s = std::make_unique<Stmt>();
    s->kind = Stmt::Kind::kCase;
    s->pos = next().pos;
    s->value = expression();
    expect_kw("OF", "after the CASE selector");
    while (!failed_ && !is_kw("ELSE") && !is_kw("END_CASE") && !at_end()) {
      CaseBranch br;
      for (;;) {
        auto lo = expression();
        std::unique_ptr<Expr> hi;
        if (accept_op("..")) hi = expression();
        br.labels.emplace_back(std::move(lo), std::move(hi));
        if (failed_ || !accept_op(",")) break;
      }
      expect_op(":", "after the CASE labels");
      if (failed_) return nullptr;
      br.body = case_body();
      s->cases.push_back(std::move(br));
    }
    if (accept_kw("ELSE")) {
      s->has_else = true;
      s->else_body = statements({"END_CASE"});
    }
    expect_kw("END_CASE", "to close CASE");
    return failed_ ? nullptr : std::move(s);
  }

  // A CASE branch ends where the next label list (`expr [.. expr] {, ...} :`) starts.
  Block case_body() {
    Block out;
    while (!failed_ && !at_end() && !is_kw("ELSE") && !is_kw("END_CASE")) {
      if (accept_op(";")) continue;
      if (starts_label()) break;
      auto st = statement();
      if (st) out.push_back(std::move(st));
    }
    return out;
  }
  bool starts_label() const {
    size_t k = i_;
    for (; k < t_.size() && t_[k].t != Tok::T::kEnd; ++k) {
      const Tok& x = t_[k];
      if (x.t == Tok::T::kOp && x.text == ":") return true;
      if (x.t == Tok::T::kOp && (x.text == ";" || x.text == ":=" || x.text == "(")) return false;
      if (x.t == Tok::T::kIdent && k > i_ && t_[k - 1].t != Tok::T::kOp) return false;
    }
    return false;
  }

  // for ::= FOR ident ':=' expr TO expr [ BY expr ] DO stmts END_FOR
  std::unique_ptr<Stmt> for_statement() {
    auto s = std::make_unique<Stmt>();
    s->kind = Stmt::Kind::kFor;
    s->pos = next().pos;
    if (peek().t != Tok::T::kIdent) {
      error(peek().pos, "expected the FOR variable");
      return nullptr;
    }
    s->target = next().text;
    expect_op(":=", "after the FOR variable");
    if (failed_) return nullptr;
    s->from = expression();
    expect_kw("TO", "in FOR");
    if (failed_) return nullptr;
    s->to = expression();
    if (accept_kw("BY")) s->by = expression();
    expect_kw("DO", "in FOR");
    if (failed_) return nullptr;
    ++loops_;
    s->body = statements({"END_FOR"});
    --loops_;
    expect_kw("END_FOR", "to close FOR");
    return failed_ ? nullptr : std::move(s);
  }

  // while ::= WHILE expr DO stmts END_WHILE
  std::unique_ptr<Stmt> while_statement() {
    auto s = std::make_unique<Stmt>();
    s->kind = Stmt::Kind::kWhile;
    s->pos = next().pos;
    s->value = expression();
    expect_kw("DO", "in WHILE");
    if (failed_) return nullptr;
    ++loops_;
    s->body = statements({"END_WHILE"});
    --loops_;
    expect_kw("END_WHILE", "to close WHILE");
    return failed_ ? nullptr : std::move(s);
  }

  // repeat ::= REPEAT stmts UNTIL expr END_REPEAT
  std::unique_ptr<Stmt> repeat_statement() {
    auto s = std::make_unique<Stmt>();
    s->kind = Stmt::Kind::kRepeat;
    s->pos = next().pos;
    ++loops_;
    s->body = statements({"UNTIL"});
    --loops_;
    expect_kw("UNTIL", "in REPEAT");
    if (failed_) return nullptr;
    s->value = expression();
    expect_kw("END_REPEAT", "to close REPEAT");
    return failed_ ? nullptr : std::move(s);
  }

  std::unique_ptr<Expr> binary(std::unique_ptr<Expr> a, BinOp op, std::unique_ptr<Expr> b, SourcePos p) {
    auto e = std::make_unique<Expr>();
    e->kind = Expr::Kind::kBinary;
    e->op = op;
    e->pos = p;
    e->args.push_back(std::move(a));
    e->args.push_back(std::move(b));
    return e;
  }

  // expression ::= xor_expr { OR xor_expr }
  std::unique_ptr<Expr> expression() {
    if (++depth_ > 200) {
      error(peek().pos, "expression nested too deeply");
      return nullptr;
    }
    auto a = xor_expr();
    while (!failed_ && is_kw("OR")) {
      const SourcePos p = next().pos;
      a = binary(std::move(a), BinOp::kOr, xor_expr(), p);
    }
    --depth_;
    return a;
  }
  // xor_expr ::= and_expr { XOR and_expr }
  std::unique_ptr<Expr> xor_expr() {
    auto a = and_expr();
    while (!failed_ && is_kw("XOR")) {
      const SourcePos p = next().pos;
      a = binary(std::move(a), BinOp::kXor, and_expr(), p);
    }
    return a;
  }
  // and_expr ::= cmp_expr { (AND | '&') cmp_expr }
  std::unique_ptr<Expr> and_expr() {
    auto a = eq_expr();
    while (!failed_ && (is_kw("AND") || (peek().t == Tok::T::kOp && peek().text == "&"))) {
      const SourcePos p = next().pos;
      a = binary(std::move(a), BinOp::kAnd, eq_expr(), p);
    }
    return a;
  }
  // eq_expr ::= rel_expr { ('=' | '<>') rel_expr }
  std::unique_ptr<Expr> eq_expr() {
    auto a = rel_expr();
    while (!failed_ && peek().t == Tok::T::kOp && (peek().text == "=" || peek().text == "<>")) {
      const Tok& t = next();
      a = binary(std::move(a), t.text == "=" ? BinOp::kEq : BinOp::kNe, rel_expr(), t.pos);
    }
    return a;
  }
  // rel_expr ::= add_expr { ('<' | '>' | '<=' | '>=') add_expr }
  std::unique_ptr<Expr> rel_expr() {
    auto a = add_expr();
    while (!failed_ && peek().t == Tok::T::kOp &&
           (peek().text == "<" || peek().text == ">" || peek().text == "<=" || peek().text == ">=")) {
      const Tok& t = next();
      const BinOp op = t.text == "<" ? BinOp::kLt : t.text == ">" ? BinOp::kGt
                       : t.text == "<=" ? BinOp::kLe : BinOp::kGe;
      a = binary(std::move(a), op, add_expr(), t.pos);
    }
    return a;
  }
  // add_expr ::= mul_expr { ('+' | '-') mul_expr }
  std::unique_ptr<Expr> add_expr() {
    auto a = mul_expr();
    while (!failed_ && peek().t == Tok::T::kOp && (peek().text == "+" || peek().text == "-")) {
      const Tok& t = next();
      a = binary(std::move(a), t.text == "+" ? BinOp::kAdd : BinOp::kSub, mul_expr(), t.pos);
    }
    return a;
  }
  // mul_expr ::= pow_expr { ('*' | '/' | MOD) pow_expr }
  std::unique_ptr<Expr> mul_expr() {
    auto a = pow_expr();
    while (!failed_ && ((peek().t == Tok::T::kOp && (peek().text == "*" || peek().text == "/")) || is_kw("MOD"))) {
      const Tok& t = next();
      const BinOp op = t.text == "*" ? BinOp::kMul : t.text == "/" ? BinOp::kDiv : BinOp::kMod;
      a = binary(std::move(a), op, pow_expr(), t.pos);
    }
    return a;
  }
  // pow_expr ::= unary { '**' unary }
  std::unique_ptr<Expr> pow_expr() {
    auto a = unary();
    while (!failed_ && accept_op("**")) {
      a = binary(std::move(a), BinOp::kExpt, unary(), t_[i_ - 1].pos);
    }
    return a;
  }
  // unary ::= ('-' | NOT) unary | primary
  std::unique_ptr<Expr> unary() {
    if (++depth_ > 200) {
      error(peek().pos, "expression nested too deeply");
      return nullptr;
    }
    std::unique_ptr<Expr> r;
    if (is_kw("NOT") || (peek().t == Tok::T::kOp && peek().text == "-")) {
      auto e = std::make_unique<Expr>();
      e->kind = peek().text == "-" ? Expr::Kind::kNeg : Expr::Kind::kNot;
      e->pos = next().pos;
      e->args.push_back(unary());
      r = std::move(e);
    } else if (accept_op("+")) {
      r = unary();
    } else {
      r = primary();
    }
    --depth_;
    return r;
  }
  // primary ::= literal | '(' expression ')' | ident '(' args ')' | variable
  std::unique_ptr<Expr> primary() {
    const Tok& t = peek();
    auto e = std::make_unique<Expr>();
    e->pos = t.pos;
    if (t.t == Tok::T::kNumber || (t.t == Tok::T::kIdent && (t.up == "TRUE" || t.up == "FALSE"))) {
      bool b = false, tm = false;
      auto v = parse_literal(t.text, &b, &tm);
      const size_t hash = t.text.find('#');
      if (!v && hash != std::string::npos && hash > 0 &&
          std::isalpha(static_cast<unsigned char>(t.text[0])) && !elementary_type(t.text.substr(0, hash)) &&
          !date_literal_type(t.text.substr(0, hash)) &&
          t.up.compare(0, hash + 1, "T#") != 0 && t.up.compare(0, hash + 1, "TIME#") != 0) {
        // Mode#Run: a typed enumeration value, resolved by the lowering.
        ++i_;
        e->kind = Expr::Kind::kName;
        e->name = t.text;
        return e;
      }
      if (!v) {
        error(t.pos, "'" + t.text + "' is not a literal rtplc reads (integers, reals, TRUE/FALSE, T#..., D#yyyy-mm-dd, TOD#hh:mm:ss, DT#yyyy-mm-dd-hh:mm:ss; dates from 1970 to 2255)");
        return nullptr;
      }
      ++i_;
      e->kind = Expr::Kind::kLiteral;
      e->k = *v;
      if (tm) {
        const std::string prefix = hash == std::string::npos ? std::string() : upper(t.text.substr(0, hash));
        const auto dt = date_literal_type(prefix);
        e->time_type = dt ? *dt : iec::IecType::kTime;
      }
      e->is_bool = b;
      e->is_time = tm;
      e->is_real = !b && !tm && t.text.find_first_of(".eE") != std::string::npos &&
                   t.text.find('#') == std::string::npos;
      return e;
    }
    if (t.t == Tok::T::kString) {
      std::string why;
      bool wide = false;
      const auto text = parse_string_literal(t.text, &why, &wide);
      if (!text) {
        error(t.pos, why);
        return nullptr;
      }
      ++i_;
      e->kind = Expr::Kind::kLiteral;
      e->is_string = true;
      e->wide = wide;
      e->text = *text;
      return e;
    }
    if (accept_op("(")) {
      auto in = expression();
      expect_op(")", "to close '('");
      return in;
    }
    if (t.t == Tok::T::kIdent) {
      if (peek(1).t == Tok::T::kOp && peek(1).text == "(") {
        e->kind = Expr::Kind::kCall;
        e->name = next().up;
        ++i_;
        std::vector<CallArg> args;
        call_arguments(args);
        if (failed_) return nullptr;
        std::unique_ptr<Expr> en = take_en_eno(args, e->pos);
        if (failed_) return nullptr;
        for (CallArg& a : args) {
          if (a.output) {
            error(a.pos, "output assignments (=>) are not allowed in a function call inside an expression");
            return nullptr;
          }
          e->arg_names.push_back(upper(a.formal));
          e->args.push_back(std::move(a.value));
        }
        if (!en) return e;
        // EN false: the function does not run and gives its type's initial
        // value, 0 (MatIEC's TEST_EN): SEL(EN, 0, f(...)). The lowering refuses
        // it for a function that writes through VAR_IN_OUT or VAR_EXTERNAL,
        // which SEL would not keep from writing.
        e->en_guarded = true;
        auto sel = std::make_unique<Expr>();
        sel->kind = Expr::Kind::kCall;
        sel->pos = e->pos;
        sel->name = "SEL";
        sel->args.push_back(std::move(en));
        sel->args.push_back(literal(0, false, e->pos));
        sel->args.push_back(std::move(e));
        sel->arg_names = {"G", "IN0", "IN1"};
        return sel;
      }
      e->kind = Expr::Kind::kName;
      e->name = variable_path(e->args);
      return e;
    }
    error(t.pos, "expected an expression, found '" + (t.t == Tok::T::kEnd ? std::string("end of text") : t.text) + "'");
    return nullptr;
  }

  static std::unique_ptr<Expr> clone(const Expr& x) {
    auto c = std::make_unique<Expr>();
    c->kind = x.kind;
    c->pos = x.pos;
    c->k = x.k;
    c->is_bool = x.is_bool;
    c->is_time = x.is_time;
    c->is_real = x.is_real;
    c->name = x.name;
    c->op = x.op;
    c->arg_names = x.arg_names;
    c->en_guarded = x.en_guarded;
    for (const auto& a : x.args) c->args.push_back(a ? clone(*a) : nullptr);
    return c;
  }
  static bool is_true(const Expr& x) { return x.kind == Expr::Kind::kLiteral && x.is_bool && x.k != 0; }
  static std::unique_ptr<Expr> literal(double k, bool is_bool, SourcePos pos) {
    auto e = std::make_unique<Expr>();
    e->kind = Expr::Kind::kLiteral;
    e->pos = pos;
    e->k = k;
    e->is_bool = is_bool;
    return e;
  }
  // `target[index] := value`, the assignments the EN/ENO rewrites add.
  static std::unique_ptr<Stmt> assignment(const std::string& target, const std::vector<std::unique_ptr<Expr>>& index,
                                          std::unique_ptr<Expr> value, SourcePos pos, bool eno_of_call) {
    auto st = std::make_unique<Stmt>();
    st->kind = Stmt::Kind::kAssign;
    st->pos = pos;
    st->target = target;
    st->eno_of_call = eno_of_call;
    for (const auto& x : index) st->target_index.push_back(clone(*x));
    st->value = std::move(value);
    return st;
  }

  // Takes EN (an input) and ENO (an output) out of a call's arguments, as
  // OpenPLC Editor and Beremiz write them for a block with EN/ENO: returns the
  // EN expression unless there is none or it is the constant TRUE, and queues
  // `target := EN` (TRUE without EN) for `ENO => target`, which statements()
  // puts after the statement holding the call. ENO is EN: rtplc's functions
  // never stop on an error of their own.
  std::unique_ptr<Expr> take_en_eno(std::vector<CallArg>& args, SourcePos pos,
                                    std::optional<CallArg>* eno_out = nullptr) {
    std::unique_ptr<Expr> en;
    std::optional<CallArg> eno;
    for (size_t k = 0; k < args.size();) {
      const std::string f = upper(args[k].formal);
      if (f == "EN" || f == "ENO") {
        if ((f == "EN") == args[k].output) {
          error(args[k].pos, f == "EN" ? "EN is an input: EN := condition" : "ENO is an output: ENO => variable");
          return nullptr;
        }
        if (f == "EN") en = std::move(args[k].value);
        else eno = std::move(args[k]);
        args.erase(args.begin() + static_cast<std::ptrdiff_t>(k));
        continue;
      }
      ++k;
    }
    if (en && is_true(*en)) en.reset();
    if (eno && en && eno_out) {  // a call statement with EN: the caller writes ENO in its IF
      *eno_out = std::move(eno);
      return en;
    }
    if (eno) {
      pending_eno_.push_back(
          assignment(eno->target, eno->target_index, en ? clone(*en) : literal(1, true, pos), eno->pos, false));
    }
    return en;
  }

  std::vector<Tok> t_;
  DiagnosticList& d_;
  size_t i_ = 0;
  std::set<std::string> en_called_;  // instances some call statement gives EN (upper-case)
  std::vector<std::unique_ptr<Stmt>> pending_eno_;  // `ok := EN` for `ENO => ok` (take_en_eno)
  int depth_ = 0;
  int nesting_ = 0;
  int loops_ = 0;  // FOR loops around the statement being parsed
  bool failed_ = false;
};

}  // namespace

size_t string_close(std::string_view text, size_t open) {
  for (size_t k = open + 1; k < text.size(); ++k) {
    if (text[k] == '$') ++k;
    else if (text[k] == text[open]) return k;
  }
  return std::string_view::npos;
}

size_t pragma_close(std::string_view text, size_t open) {
  int depth = 0;
  for (size_t k = open; k < text.size(); ++k) {
    if (text[k] == '{') ++depth;
    else if (text[k] == '}' && --depth == 0) return k;
  }
  return std::string_view::npos;
}

Block parse_st(std::string_view text, const XmlElement& origin, DiagnosticList& diags) {
  const size_t before = diags.error_count();
  std::vector<Tok> toks = lex(text, origin, diags);
  if (diags.error_count() != before) return {};
  Parser p(std::move(toks), diags);
  Block b = p.statements({});
  if (!p.failed() && !p.at_end()) diags.error(SourcePos{}, "unexpected text after the statements");
  if (!p.failed()) p.resolve_eno(b);
  return b;
}

Block parse_st_range(std::string_view text, size_t begin, size_t end, const XmlElement& origin,
                     DiagnosticList& diags) {
  const size_t before = diags.error_count();
  std::vector<Tok> toks = lex(text.substr(0, end), origin, diags, begin);
  if (diags.error_count() != before) return {};
  Parser p(std::move(toks), diags);
  Block b = p.statements({});
  return b;
}

std::unique_ptr<Expr> parse_st_expression(std::string_view text, const XmlElement& origin,
                                          DiagnosticList& diags, size_t begin, size_t end) {
  const size_t before = diags.error_count();
  std::vector<Tok> toks = lex(text.substr(0, std::min(end, text.size())), origin, diags, begin);
  if (diags.error_count() != before) return nullptr;
  Parser p(std::move(toks), diags);
  auto e = p.whole_expression();
  return p.failed() ? nullptr : std::move(e);
}

void st_written_names(std::string_view text, std::vector<std::string>& out) {
  DiagnosticList scratch;
  XmlElement none;
  std::vector<Tok> toks = lex(text, none, scratch);
  for (size_t i = 0; i + 1 < toks.size(); ++i) {
    if (toks[i].t == Tok::T::kIdent && toks[i + 1].t == Tok::T::kOp && toks[i + 1].text == ":=")
      out.push_back(toks[i].up);
    if (toks[i].t == Tok::T::kOp && toks[i].text == "=>" && toks[i + 1].t == Tok::T::kIdent)
      out.push_back(toks[i + 1].up);
  }
}

}  // namespace rtplc::lang::plcopen
