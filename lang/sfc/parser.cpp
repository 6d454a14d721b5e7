// Recursive-descent parser for SFC programs (docs/sfc.md, "File layout"). Each
// parse function sits under its grammar rule. Errors are reported at the
// offending token; the parser then skips to the next statement keyword, so one
// run reports several mistakes.
#include "lang/sfc/parser.h"

#include <algorithm>
#include <array>
#include <string>

namespace rtplc::lang::sfc {
namespace {

// Words that start a top-level statement: where the parser resynchronises.
constexpr std::array<std::string_view, 9> kStatementWords = {
    "stime", "INPUT", "OUTPUT", "SIGNAL", "INITIAL", "STEP", "TRANSITION", "PLANT", "END_SFC"};

constexpr std::array<std::string_view, 27> kReserved = {
    "SFC",   "STEPS",     "END_SFC", "stime",    "INPUT",  "OUTPUT",     "SIGNAL",
    "MODEL", "INITIAL",   "STEP",    "END_STEP", "SUBNET", "TRANSITION", "FROM",
    "TO",    "WHEN",      "AND",     "OR",       "NOT",    "TRUE",       "FALSE",
    "PLANT", "END_PLANT", "MODULE",  "MAIN",     "EVENT",  "WHILE"};

bool is_reserved(std::string_view w) {
  return std::find(kReserved.begin(), kReserved.end(), w) != kReserved.end();
}

struct SyntaxError {};  // unwinds to the statement loop, which resynchronises

class Parser {
 public:
  Parser(const std::vector<Token>& t, DiagnosticList& d) : toks_(t), diags_(d) {}

  // chart := 'SFC' NAME [ 'STEPS' dN ] { statement } [ 'END_SFC' ] EOF
  Chart run() {
    Chart c;
    if (is_word("SFC")) {
      c.pos = cur().pos;
      next();
      try {
        NameRef n = expect_name("the program's name after SFC");
        c.name = n.name;
        if (is_word("STEPS")) {
          next();
          const Token& d = cur();
          const std::string_view w = d.kind == Tok::kName ? d.text : std::string_view{};
          uint32_t module = 0;
          if (!parse_device_word(w, 'd', &module)) {
            fail(d, "expected a module address such as d3 after STEPS (the step flags' module)");
          }
          c.steps_module = module;
          next();
        }
      } catch (const SyntaxError&) {
        recover();
      }
    } else {
      error(cur(), "an SFC program starts with 'SFC name', found " + describe(cur()));
    }
    while (cur().kind != Tok::kEof) {
      if (is_word("END_SFC")) {
        next();
        if (cur().kind != Tok::kEof)
          error(cur(), "nothing may follow END_SFC, found " + describe(cur()));
        break;
      }
      try {
        statement(c);
      } catch (const SyntaxError&) {
        recover();
      }
    }
    return c;
  }

 private:
  // statement := stime | signal | step | transition | plant
  void statement(Chart& c) {
    if (is_word("stime")) return stime(c);
    if (is_word("INPUT") || is_word("OUTPUT") || is_word("SIGNAL")) return signal(c);
    if (is_word("INITIAL") || is_word("STEP")) return step(c);
    if (is_word("TRANSITION")) return transition(c);
    if (is_word("PLANT")) return plant(c);
    fail(cur(), "expected INPUT, OUTPUT, SIGNAL, STEP, TRANSITION, PLANT or stime, found " +
                    describe(cur()));
  }

  // stime := 'stime' '(' NUMBER ')'
  void stime(Chart& c) {
    if (c.has_stime) error(cur(), "stime is given twice");
    c.stime_pos = cur().pos;
    next();
    expect(Tok::kLParen, "'(' after stime");
    const Token& n = cur();
    if (n.kind != Tok::kNumber) fail(n, "expected the period in seconds, found " + describe(n));
    c.period = n.value;
    c.has_stime = true;
    next();
    expect(Tok::kRParen, "')' after the period");
  }

  // signal := ('INPUT' | 'SIGNAL') NAME '=' call [ model ]
  //         | 'OUTPUT' NAME [ '=' call ] [ model ]
  // model  := 'MODEL' NAME NAME
  void signal(Chart& c) {
    Signal s;
    const std::string_view w = cur().text;
    s.role = w == "INPUT"    ? Signal::Role::kInput
             : w == "OUTPUT" ? Signal::Role::kOutput
                             : Signal::Role::kSignal;
    next();
    NameRef n = expect_name("a name for the " + std::string(w == "INPUT"    ? "input"
                                                            : w == "OUTPUT" ? "output"
                                                                            : "signal"));
    s.name = n.name;
    s.pos = n.pos;
    if (cur().kind == Tok::kEquals || s.role != Signal::Role::kOutput) {
      expect(Tok::kEquals, "'=' and a block call");
      s.call = call();
    }
    if (is_word("MODEL")) {
      s.model_pos = cur().pos;
      next();
      s.model_on = expect_name("the plant place for true after MODEL").name;
      s.model_off = expect_name("the plant place for false after MODEL").name;
    }
    c.signals.push_back(std::move(s));
  }

  // call := NAME '(' [ arg { ',' arg } ] ')'
  // arg  := NAME | NUMBER | STRING
  Call call() {
    Call k;
    NameRef n = expect_name("a block name such as ddi or time");
    k.block = n.name;
    k.pos = n.pos;
    expect(Tok::kLParen, "'(' after the block name");
    if (cur().kind == Tok::kRParen) {
      next();
      return k;
    }
    for (;;) {
      const Token& t = cur();
      Arg a;
      a.pos = t.pos;
      if (t.kind == Tok::kName && !is_reserved(t.text)) {
        a.type = Arg::Type::kName;
        a.text = std::string(t.text);
      } else if (t.kind == Tok::kNumber) {
        a.type = Arg::Type::kNumber;
        a.number = t.value;
      } else if (t.kind == Tok::kString) {
        a.type = Arg::Type::kString;
        a.text = std::string(t.text);
      } else {
        fail(t, "expected an argument (a name, number or \"label\"), found " + describe(t));
      }
      next();
      k.args.push_back(std::move(a));
      if (cur().kind == Tok::kComma) {
        next();
        continue;
      }
      expect(Tok::kRParen, "',' or ')' in the argument list");
      return k;
    }
  }

  // step   := [ 'INITIAL' ] 'STEP' NAME { action | subnet } 'END_STEP'
  // action := QUALIFIER NAME [ NUMBER ]  QUALIFIER: N S R P P1 P0 L D SD DS SL
  // subnet := 'SUBNET' NAME { ',' NAME }
  void step(Chart& c) {
    Step s;
    if (is_word("INITIAL")) {
      s.initial = true;
      next();
      if (!is_word("STEP")) fail(cur(), "expected STEP after INITIAL, found " + describe(cur()));
    }
    next();
    NameRef n = expect_name("the step's name");
    s.name = n.name;
    s.pos = n.pos;
    while (!is_word("END_STEP")) {
      const Token& t = cur();
      if (t.kind == Tok::kEof || is_statement_word()) {
        error(t, "step " + s.name + " is not closed: expected END_STEP, found " + describe(t));
        c.steps.push_back(std::move(s));
        return;
      }
      try {
        if (is_word("SUBNET")) {
          s.subnet_pos = t.pos;
          next();
          s.subnet.push_back(expect_name("a plant module after SUBNET"));
          while (cur().kind == Tok::kComma) {
            next();
            s.subnet.push_back(expect_name("a plant module after ','"));
          }
          continue;
        }
        s.actions.push_back(action());
      } catch (const SyntaxError&) {
        // Skip to something that can start the next action line.
        while (cur().kind != Tok::kEof && !is_word("END_STEP") && !is_statement_word() &&
               cur().pos.line == t.pos.line) {
          next();
        }
      }
    }
    next();
    c.steps.push_back(std::move(s));
  }

  Action action() {
    const Token& q = cur();
    static constexpr std::array<std::string_view, 11> kQualifiers = {
        "N", "S", "R", "P", "P1", "P0", "L", "D", "SD", "DS", "SL"};
    if (q.kind != Tok::kName ||
        std::find(kQualifiers.begin(), kQualifiers.end(), q.text) == kQualifiers.end()) {
      fail(q,
           "expected an action qualifier (N, S, R, P, P1, P0, L, D, SD, DS or SL) or END_STEP, "
           "found " +
               describe(q));
    }
    Action a;
    a.qualifier = std::string(q.text);
    a.pos = q.pos;
    next();
    NameRef t = expect_name("the output the action drives");
    a.target = t.name;
    a.target_pos = t.pos;
    if (cur().kind == Tok::kNumber) {
      a.seconds = cur().value;
      a.time_pos = cur().pos;
      next();
    }
    return a;
  }

  // transition := 'TRANSITION' NAME 'FROM' steps 'TO' steps 'WHEN' expr
  // steps      := NAME | '(' NAME { ',' NAME } ')'
  void transition(Chart& c) {
    next();
    Transition t;
    NameRef n = expect_name("the transition's name");
    t.name = n.name;
    t.pos = n.pos;
    expect_word("FROM", "FROM and the step(s) it leaves");
    t.from = steps();
    expect_word("TO", "TO and the step(s) it activates");
    t.to = steps();
    expect_word("WHEN", "WHEN and its condition (WHEN TRUE for none)");
    t.condition = expr();
    c.transitions.push_back(std::move(t));
  }

  std::vector<NameRef> steps() {
    std::vector<NameRef> v;
    if (cur().kind != Tok::kLParen) {
      v.push_back(expect_name("a step name"));
      return v;
    }
    next();
    v.push_back(expect_name("a step name"));
    while (cur().kind == Tok::kComma) {
      next();
      v.push_back(expect_name("a step name"));
    }
    expect(Tok::kRParen, "',' or ')' after the step names");
    return v;
  }

  // expr   := term { 'OR' term }
  // term   := factor { 'AND' factor }
  // factor := 'NOT' factor | '(' expr ')' | 'TRUE' | 'FALSE' | NAME
  Expr expr() {
    if (++depth_ > kMaxDepth) fail(cur(), "condition nested too deeply");
    Expr e = term();
    if (is_word("OR")) {
      Expr o;
      o.op = Expr::Op::kOr;
      o.pos = e.pos;
      o.kids.push_back(std::move(e));
      while (is_word("OR")) {
        next();
        o.kids.push_back(term());
      }
      e = std::move(o);
    }
    --depth_;
    return e;
  }

  Expr term() {
    Expr e = factor();
    if (is_word("AND")) {
      Expr a;
      a.op = Expr::Op::kAnd;
      a.pos = e.pos;
      a.kids.push_back(std::move(e));
      while (is_word("AND")) {
        next();
        a.kids.push_back(factor());
      }
      e = std::move(a);
    }
    return e;
  }

  Expr factor() {
    const Token& t = cur();
    Expr e;
    e.pos = t.pos;
    if (is_word("NOT")) {
      if (++depth_ > kMaxDepth) fail(t, "condition nested too deeply");
      next();
      e.op = Expr::Op::kNot;
      e.kids.push_back(factor());
      --depth_;
      return e;
    }
    if (t.kind == Tok::kLParen) {
      next();
      e = expr();
      expect(Tok::kRParen, "')' to close the condition");
      return e;
    }
    if (is_word("TRUE") || is_word("FALSE")) {
      e.op = is_word("TRUE") ? Expr::Op::kTrue : Expr::Op::kFalse;
      next();
      return e;
    }
    if (t.kind == Tok::kName && !is_reserved(t.text)) {
      e.op = Expr::Op::kName;
      e.name = std::string(t.text);
      next();
      return e;
    }
    fail(t,
         "expected a condition (a signal, Step.X, NOT, TRUE, FALSE or '('), found " + describe(t));
  }

  // plant  := 'PLANT' { module | event } 'END_PLANT'
  // module := 'MODULE' NAME [ 'MAIN' ] ':' place { place }      place := NAME [ '*' ]
  // event  := 'EVENT' NAME ':' NAME '->' NAME [ 'WHILE' NAME { ',' NAME } ]
  void plant(Chart& c) {
    const Token& start = cur();
    next();
    while (!is_word("END_PLANT")) {
      const Token& t = cur();
      if (t.kind == Tok::kEof || (is_statement_word() && !is_word("PLANT"))) {
        error(start, "PLANT is not closed: expected END_PLANT before " + describe(t));
        return;
      }
      try {
        if (is_word("MODULE")) {
          module(c);
        } else if (is_word("EVENT")) {
          event(c);
        } else {
          fail(t, "expected MODULE, EVENT or END_PLANT, found " + describe(t));
        }
      } catch (const SyntaxError&) {
        next();
        while (cur().kind != Tok::kEof && !is_word("MODULE") && !is_word("EVENT") &&
               !is_word("END_PLANT") && !is_statement_word()) {
          next();
        }
      }
    }
    next();
  }

  void module(Chart& c) {
    next();
    Module m;
    NameRef n = expect_name("the module's name");
    m.name = n.name;
    m.pos = n.pos;
    if (is_word("MAIN")) {
      m.main = true;
      next();
    }
    expect(Tok::kColon, "':' and the module's places");
    while (cur().kind == Tok::kName && !is_reserved(cur().text)) {
      PlaceDecl p;
      p.name = std::string(cur().text);
      p.pos = cur().pos;
      next();
      if (cur().kind == Tok::kStar) {
        p.initial = true;
        next();
      }
      m.places.push_back(std::move(p));
    }
    if (m.places.empty()) fail(cur(), "expected the module's places, found " + describe(cur()));
    c.modules.push_back(std::move(m));
  }

  void event(Chart& c) {
    next();
    Event e;
    NameRef n = expect_name("the event's name");
    e.name = n.name;
    e.pos = n.pos;
    expect(Tok::kColon, "':' and 'place -> place'");
    e.from = expect_name("the place the event leaves");
    expect(Tok::kArrow, "'->' between the two places");
    e.to = expect_name("the place the event marks");
    if (is_word("WHILE")) {
      next();
      e.reads.push_back(expect_name("a step or place after WHILE"));
      while (cur().kind == Tok::kComma) {
        next();
        e.reads.push_back(expect_name("a step or place after ','"));
      }
    }
    c.events.push_back(std::move(e));
  }

  // ---- helpers ----
  const Token& cur() const { return toks_[i_]; }
  void next() {
    if (i_ + 1 < toks_.size()) ++i_;
  }
  bool is_word(std::string_view w) const { return cur().kind == Tok::kName && cur().text == w; }
  bool is_statement_word() const {
    return cur().kind == Tok::kName && std::find(kStatementWords.begin(), kStatementWords.end(),
                                                 cur().text) != kStatementWords.end();
  }

  static std::string describe(const Token& t) {
    switch (t.kind) {
      case Tok::kEof:
        return "the end of the file";
      case Tok::kName:
        return "'" + std::string(t.text) + "'";
      case Tok::kString:
        return "the string \"" + std::string(t.text) + "\"";
      case Tok::kNumber:
        return "the number " + std::string(t.text);
      default:
        return tok_name(t.kind);
    }
  }

  NameRef expect_name(const std::string& what) {
    const Token& t = cur();
    if (t.kind != Tok::kName) fail(t, "expected " + what + ", found " + describe(t));
    if (is_reserved(t.text)) {
      fail(t, "expected " + what + ", found the keyword " + describe(t) +
                  " (keywords cannot be names)");
    }
    NameRef n{std::string(t.text), t.pos};
    next();
    return n;
  }
  void expect(Tok k, const std::string& what) {
    if (cur().kind != k) fail(cur(), "expected " + what + ", found " + describe(cur()));
    next();
  }
  void expect_word(std::string_view w, const std::string& what) {
    if (!is_word(w)) fail(cur(), "expected " + what + ", found " + describe(cur()));
    next();
  }

  static bool parse_device_word(std::string_view w, char letter, uint32_t* out) {
    if (w.size() < 2 || w.size() > 6 || w[0] != letter) return false;
    uint32_t v = 0;
    for (size_t k = 1; k < w.size(); ++k) {
      if (w[k] < '0' || w[k] > '9') return false;
      v = v * 10 + static_cast<uint32_t>(w[k] - '0');
    }
    *out = v;
    return true;
  }

  void error(const Token& t, std::string msg) {
    diags_.error(t.pos, std::move(msg), std::max<uint32_t>(1, t.length));
  }
  [[noreturn]] void fail(const Token& t, std::string msg) {
    error(t, std::move(msg));
    throw SyntaxError{};
  }

  // Skips to the next top-level statement word.
  void recover() {
    depth_ = 0;
    next();
    while (cur().kind != Tok::kEof && !is_statement_word()) next();
  }

  static constexpr int kMaxDepth = 200;
  const std::vector<Token>& toks_;
  DiagnosticList& diags_;
  size_t i_ = 0;
  int depth_ = 0;
};

}  // namespace

Chart parse(const std::vector<Token>& tokens, DiagnosticList& diags) {
  return Parser(tokens, diags).run();
}

}  // namespace rtplc::lang::sfc
