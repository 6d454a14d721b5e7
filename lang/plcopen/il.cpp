// IL bodies -> blocks (docs/plcopen.md, "IL"): the current result (CR) is a
// value, and the jumps become if-conversion. Every instruction runs under a
// predicate P, true when control reaches it: `ST x` is x := sel(P, CR, x), S
// and R are guarded likewise, a conditional jump splits P into the part that
// jumps (carried to its label with its CR) and the part that falls through,
// and a label ORs the predicates that reach it and selects their CRs. Only
// one path is taken in a cycle, so the selections are exact. A conditional
// CAL is if-converted like an ST IF (a user FB keeps its variables, a
// standard FB its state, when not called). A backward jump is a real loop
// (docs/plcopen.md, "IL"): the body's variables, CR and P get homes, set
// where control falls into the label and before the jump, read after the
// label; the jump is the executor's counted Loop instruction.
#include <cctype>
#include <map>
#include <optional>
#include <set>

#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {
namespace {

struct Line {
  size_t begin = 0, end = 0;  // the instruction (after any label)
  std::string label;
  SourcePos label_pos;
};


// Which paths a predicate covers, to know when the paths split by conditional
// jumps have all joined again (a CAL there is unconditional). Atom 0 is "every
// path"; splitting atom a by a condition makes two children, and a set that
// holds both children of an atom covers the atom.
class PathSet {
 public:
  std::set<int> atoms{0};
  static std::pair<PathSet, PathSet> split(const PathSet& p, std::vector<std::pair<int, int>>& children,
                                           std::vector<int>& parent) {
    PathSet t, f;
    t.atoms.clear();
    f.atoms.clear();
    for (int a : p.atoms) {
      const int ta = static_cast<int>(parent.size()), fa = ta + 1;
      parent.push_back(a);
      parent.push_back(a);
      children.emplace_back(ta, fa);
      t.atoms.insert(ta);
      f.atoms.insert(fa);
    }
    return {t, f};
  }
  void join(const PathSet& o, const std::vector<int>& parent) {
    atoms.insert(o.atoms.begin(), o.atoms.end());
    for (bool changed = true; changed;) {
      changed = false;
      for (int a : atoms) {
        if (a == 0) continue;
        const int sib = (a % 2 == 1) ? a + 1 : a - 1;  // children are made in pairs (odd, even)
        if (atoms.count(sib)) {
          const int par = parent[static_cast<size_t>(a)];
          atoms.erase(a);
          atoms.erase(sib);
          atoms.insert(par);
          changed = true;
          break;
        }
      }
    }
  }
  bool all() const { return atoms.size() == 1 && *atoms.begin() == 0; }
};

}  // namespace

void Lowering::lower_il(Scope& s, const Body& body) {
  il_result_.reset();
  const std::string& src = body.source;
  const XmlElement& origin = *body.text;
  // Comments become spaces, so offsets (and positions) stay those of the file.
  std::string t = src;
  for (size_t i = 0; i + 1 < t.size(); ++i) {
    if (t[i] == '(' && t[i + 1] == '*') {
      const size_t e = t.find("*)", i + 2);
      const size_t stop = e == std::string::npos ? t.size() : e + 2;
      for (size_t k = i; k < stop; ++k) {
        if (t[k] != '\n') t[k] = ' ';
      }
      i = stop - 1;
    }
  }
  auto pos_at = [&](size_t off) { return origin.text_position(off); };
  std::vector<Line> lines;
  for (size_t b = 0; b <= t.size();) {
    size_t e = t.find('\n', b);
    if (e == std::string::npos) e = t.size();
    Line l;
    size_t i = b;
    while (i < e && std::isspace(static_cast<unsigned char>(t[i]))) ++i;
    size_t j = i;
    while (j < e && ident_char(t[j])) ++j;
    size_t k = j;
    while (k < e && (t[k] == ' ' || t[k] == '\t')) ++k;
    if (j > i && k < e && t[k] == ':' && (k + 1 >= e || t[k + 1] != '=')) {
      l.label = upper(t.substr(i, j - i));
      l.label_pos = pos_at(i);
      i = k + 1;
      while (i < e && std::isspace(static_cast<unsigned char>(t[i]))) ++i;
    }
    size_t end = e;
    while (end > i && std::isspace(static_cast<unsigned char>(t[end - 1]))) --end;
    l.begin = i;
    l.end = end;
    if (!l.label.empty() || l.end > l.begin) lines.push_back(l);
    b = e + 1;
  }
  std::map<std::string, size_t> label_line;
  for (size_t n = 0; n < lines.size(); ++n) {
    if (lines[n].label.empty()) continue;
    if (!label_line.emplace(lines[n].label, n).second) {
      d_.error(lines[n].label_pos, "label " + lines[n].label + " is defined twice");
      return;
    }
  }

  // The labels a backward jump goes to (each is a loop's head).
  std::set<std::string> loop_heads;
  for (size_t n = 0; n < lines.size(); ++n) {
    const Line& l = lines[n];
    size_t i = l.begin;
    while (i < l.end && ident_char(t[i])) ++i;
    const std::string op = upper(t.substr(l.begin, i - l.begin));
    if (op != "JMP" && op != "JMPC" && op != "JMPCN") continue;
    while (i < l.end && std::isspace(static_cast<unsigned char>(t[i]))) ++i;
    auto it = label_line.find(upper(t.substr(i, l.end - i)));
    if (it != label_line.end() && it->second <= n) loop_heads.insert(it->first);
  }

  Emitter& em = em_;
  // With a loop: a home for every variable the body may write (all of its
  // POU's, and the globals it names), for CR and for P, made here where
  // they always run.
  std::vector<std::pair<Var*, LoopHome>> homes;
  struct Head {
    LoopHome cr;                // CR as it falls in or jumps back
    bool cr_loaded = false;     // the head's first instruction is LD or LDN: CR's value there is never read
    std::optional<LoopHome> p;  // P, when not every path reaches the head
    uint32_t run = 0;           // its first run
  };
  std::map<std::string, Head> heads;
  const SourcePos body_pos = body.pos;
  if (!loop_heads.empty()) {
    std::vector<Var*> vs;
    std::set<const Var*> seen;
    for (auto& [name, v] : s.vars) var_leaves(*v, vs, seen);
    if (s.globals) {
      for (size_t i = 0; i < t.size();) {
        if (!ident_char(t[i]) || std::isdigit(static_cast<unsigned char>(t[i]))) {
          ++i;
          continue;
        }
        size_t j = i;
        while (j < t.size() && ident_char(t[j])) ++j;
        auto g = s.globals->vars.find(upper(t.substr(i, j - i)));
        if (g != s.globals->vars.end()) var_leaves(*g->second, vs, seen);
        i = j;
      }
    }
    if (conditional()) (void)active(body_pos);
    for (Var* v : vs) {
      // A located input the body writes too (MatIEC's: lasts until the next cycle).
      if ((v->role != Var::Role::kPlain && v->role != Var::Role::kInput) || (v->decl && v->decl->constant)) continue;
      homes.emplace_back(v, make_home_for(*v, body_pos));
    }
  }
  // The variables' homes, and `extra` (the current result's and P's), set at
  // once (Lowering::set_homes): LD a at a loop's head makes CR a's home.
  auto sync_homes = [&](SourcePos pos, std::vector<std::pair<const LoopHome*, Value>> extra) {
    for (auto& [v, h] : homes) extra.emplace_back(&h, read(*v, pos));
    set_homes(extra, pos);
  };
  Value P = constant(1, true);
  uint32_t cr_mixed = 0;  // the line of the label since which CR has no one type (a STRING and a number met); 0: none
  PathSet paths;  // which paths P covers
  std::vector<int> parent{0};
  std::vector<std::pair<int, int>> children;
  Value CR = constant(0, true);
  struct Paren {
    std::string op;
    bool negate;
    Value cr;
  };
  std::vector<Paren> stack;
  struct Arrival {
    Value pred, cr;
    PathSet paths;
  };
  std::map<std::string, std::vector<Arrival>> pending;

  auto operand = [&](size_t b, size_t e, SourcePos pos) -> std::optional<Value> {
    if (b >= e) {
      d_.error(pos, "this instruction needs an operand");
      return std::nullopt;
    }
    auto ex = parse_st_expression(src, origin, d_, b, e);
    if (!ex) return std::nullopt;
    return eval(s, *ex);
  };
  auto apply = [&](const std::string& op, Value a, Value b, SourcePos pos) -> std::optional<Value> {
    static const std::pair<const char*, BinOp> kOps[] = {
        {"AND", BinOp::kAnd}, {"OR", BinOp::kOr}, {"XOR", BinOp::kXor}, {"ADD", BinOp::kAdd},
        {"SUB", BinOp::kSub}, {"MUL", BinOp::kMul}, {"DIV", BinOp::kDiv}, {"MOD", BinOp::kMod},
        {"GT", BinOp::kGt},   {"GE", BinOp::kGe},   {"EQ", BinOp::kEq},   {"NE", BinOp::kNe},
        {"LE", BinOp::kLe},   {"LT", BinOp::kLt}};
    for (const auto& [n, o] : kOps) {
      if (op == n) return operate(o, a, b, pos);
    }
    return std::nullopt;
  };

  for (size_t n = 0; n < lines.size() && !d_.has_errors(); ++n) {
    const Line& l = lines[n];
    if (!l.label.empty()) {
      // Merge every path that reaches the label.
      auto it = pending.find(l.label);
      if (it != pending.end()) {
        for (const Arrival& a : it->second) {
          if (a.cr.str != CR.str || a.cr.wide != CR.wide) {
            // A STRING on one way here, a number on another: no value until
            // the next LD (using it is refused, below).
            cr_mixed = std::max(l.label_pos.line, 1u);
            CR = constant(0, false);
          } else {
            CR = em.select(a.pred, a.cr, CR, l.label_pos);
          }
          P = em.binary(BinOp::kOr, P, a.pred, l.label_pos);
          paths.join(a.paths, parent);
        }
        if (paths.all()) P = constant(1, true);  // every path is back
        pending.erase(it);
      }
      if (loop_heads.count(l.label) != 0) {
        // A loop's head: what falls in goes to the homes, the jump back sets
        // them too, and from here on everything reads them.
        Head& hd = heads[l.label];
        // The first instruction from here: when it loads, CR may come back
        // from the jump as another type (a STRING in, a comparison back).
        for (size_t k = n; k < lines.size(); ++k) {
          if (lines[k].begin >= lines[k].end) continue;
          size_t e = lines[k].begin;
          while (e < lines[k].end && ident_char(t[e])) ++e;
          const std::string first = upper(t.substr(lines[k].begin, e - lines[k].begin));
          hd.cr_loaded = first == "LD" || first == "LDN";
          break;
        }
        hd.cr = make_home_for(CR, s.path + ".$cr", l.label_pos);
        std::vector<std::pair<const LoopHome*, Value>> extra{{&hd.cr, CR}};
        if (!(P.is_const && P.k != 0)) {
          hd.p = make_home(s.path + ".$p", true, false, l.label_pos);
          extra.emplace_back(&*hd.p, P);
        }
        sync_homes(l.label_pos, std::move(extra));
        hd.run = static_cast<uint32_t>(em.size());
        for (auto& [v, h] : homes) v->cur = h.value;
        CR = hd.cr.value;
        if (hd.p) P = hd.p->value;
      }
    }
    if (l.end <= l.begin) continue;
    const SourcePos pos = pos_at(l.begin);
    size_t i = l.begin;
    std::string op;
    if (t[i] == ')') {
      op = ")";
      ++i;
    } else {
      while (i < l.end && ident_char(t[i])) ++i;
      op = upper(t.substr(l.begin, i - l.begin));
    }
    if (op.empty()) {
      d_.error(pos, "expected an IL operator, found '" + t.substr(l.begin, l.end - l.begin) + "'");
      return;
    }
    size_t ob = i;
    while (ob < l.end && std::isspace(static_cast<unsigned char>(t[ob]))) ++ob;
    bool paren = false;
    if (ob < l.end && t[ob] == '(' && op != "CAL" && op != "CALC" && op != "CALCN") {
      paren = true;
      ++ob;
      while (ob < l.end && std::isspace(static_cast<unsigned char>(t[ob]))) ++ob;
    }
    const bool has_operand = ob < l.end;
    if (op == ")") {
      if (stack.empty()) {
        d_.error(pos, "')' without an opening '('");
        return;
      }
      Paren pr = stack.back();
      stack.pop_back();
      Value inner = pr.negate ? em.unary_not(em.to_digital(CR, pos), pos) : CR;
      auto r = apply(pr.op, pr.cr, inner, pos);
      if (!r) {
        d_.error(pos, "'" + pr.op + "(' cannot take a parenthesised operand");
        return;
      }
      CR = *r;
      continue;
    }
    if (op == "WHILE" || op == "REPEAT" || op == "FOR") {
      d_.error(pos, op + " is not IL");
      return;
    }
    const bool neg = op == "ANDN" || op == "ORN" || op == "XORN";
    const std::string base = neg ? op.substr(0, op.size() - 1) : op;
    if (cr_mixed != 0 && op != "LD" && op != "LDN" && op != "JMP" && op != "CAL" && op != "RET") {
      d_.error(pos, op + " uses the current result, which is a STRING on one way to the label at line " +
                        std::to_string(cr_mixed) + " and a number on another: load it (LD) after the label");
      break;
    }
    if (op == "LD" || op == "LDN") {
      cr_mixed = 0;
      auto v = operand(ob, l.end, pos);
      if (!v) return;
      CR = op == "LDN" ? em.unary_not(em.to_digital(*v, pos), pos) : *v;
    } else if (op == "ST" || op == "STN" || op == "S" || op == "R") {
      auto ex = has_operand ? parse_st_expression(src, origin, d_, ob, l.end) : nullptr;
      if (!ex) {
        if (!has_operand) d_.error(pos, op + " needs a variable");
        return;
      }
      if (ex->kind != Expr::Kind::kName) {
        d_.error(pos, op + " needs a variable");
        return;
      }
      Var* target = resolve_static(s, ex->name, ex->args, pos);
      if (!target) return;
      if (op == "ST" || op == "STN") {
        const Value v = op == "STN" ? em.unary_not(em.to_digital(CR, pos), pos) : CR;
        assign(*target, em.select(P, v, read(*target, pos), pos), pos);
      } else {
        const Value fire = em.binary(BinOp::kAnd, P, em.to_digital(CR, pos), pos);
        const Value cur = em.to_digital(read(*target, pos), pos);
        assign(*target, op == "S" ? em.binary(BinOp::kOr, cur, fire, pos)
                                  : em.binary(BinOp::kAnd, cur, em.unary_not(fire, pos), pos), pos);
      }
    } else if (op == "NOT") {
      CR = operate("NOT", CR, pos);  // BOOL, or bit-wise in the operand's width
    } else if (op == "JMP" || op == "JMPC" || op == "JMPCN") {
      std::string target = upper(t.substr(ob, l.end - ob));
      auto it = label_line.find(target);
      if (it == label_line.end()) {
        d_.error(pos, "jump to label '" + target + "', which this body does not define");
        return;
      }
      const Value c = em.to_digital(CR, pos);
      if (it->second <= n) {
        // Back to a loop's head: taken where P (and the condition, and the
        // branch around the body) holds; falling through leaves P as it was
        // (past a JMPC, P true means the condition was false).
        Value pred = op == "JMP" ? P
                     : op == "JMPC" ? em.binary(BinOp::kAnd, P, c, pos)
                                    : em.binary(BinOp::kAnd, P, em.unary_not(c, pos), pos);
        if (conditional()) pred = em.binary(BinOp::kAnd, pred, active(pos), pos);
        const Head& hd = heads.at(target);
        std::vector<std::pair<const LoopHome*, Value>> extra;
        if (!hd.cr_loaded || (CR.str == hd.cr.value.str && CR.wide == hd.cr.value.wide)) extra.emplace_back(&hd.cr, CR);
        if (hd.p) extra.emplace_back(&*hd.p, constant(1, true));
        sync_homes(pos, std::move(extra));
        std::optional<size_t> skip;
        if (!(pred.is_const && pred.k != 0)) {
          skip = em.emit_flow("jz", em.fresh(s.path + ".$il_back"), pos, {em.ref(em.to_digital(pred, pos), pos)}, 0);
        }
        em.emit_flow("loop", em.fresh(s.path + ".$il_loop"), pos, {}, hd.run);
        if (skip) em.block(*skip).target = static_cast<uint32_t>(em.size());
        if (op == "JMP") {
          paths.atoms.clear();
          P = constant(0, true);
        }
        continue;
      }
      const Value pred = op == "JMP" ? P
                         : op == "JMPC" ? em.binary(BinOp::kAnd, P, c, pos)
                                        : em.binary(BinOp::kAnd, P, em.unary_not(c, pos), pos);
      if (op == "JMP") {
        pending[target].push_back({pred, CR, paths});
        paths.atoms.clear();
      } else {
        auto [taken, fall] = PathSet::split(paths, children, parent);
        if (op == "JMPCN") std::swap(taken, fall);
        pending[target].push_back({pred, CR, taken});
        paths = fall;
      }
      P = op == "JMP" ? constant(0, true)
          : op == "JMPC" ? em.binary(BinOp::kAnd, P, em.unary_not(c, pos), pos)
                         : em.binary(BinOp::kAnd, P, c, pos);
    } else if (op == "RET" || op == "RETC" || op == "RETCN") {
      const Value c = em.to_digital(CR, pos);
      if (op == "RET") {
        paths.atoms.clear();
      } else {
        auto [taken, fall] = PathSet::split(paths, children, parent);
        paths = op == "RETC" ? fall : taken;
      }
      P = op == "RET" ? constant(0, true)
          : op == "RETC" ? em.binary(BinOp::kAnd, P, em.unary_not(c, pos), pos)
                         : em.binary(BinOp::kAnd, P, c, pos);
    } else if (op == "CAL" || op == "CALC" || op == "CALCN") {
      std::string call = t.substr(ob, l.end - ob);
      if (call.find('(') == std::string::npos) {
        d_.error(pos, "CAL " + call + " without arguments: give them in the call, CAL " + call + "(IN := ...)");
        return;
      }
      Block blk = parse_st_range(src, ob, l.end, origin, d_);
      if (d_.has_errors()) return;
      // The call happens where P holds (CALC: and CR, CALCN: and not CR): if-converted
      // like an ST IF, so a user FB keeps its variables when it is not called.
      const Value c = em.to_digital(CR, pos);
      const Value when = op == "CAL" ? P
                         : op == "CALC" ? em.binary(BinOp::kAnd, P, c, pos)
                                        : em.binary(BinOp::kAnd, P, em.unary_not(c, pos), pos);
      if (when.is_const && when.k != 0) lower_st(s, blk);
      else lower_st_guarded(s, blk, when, pos);
    } else if (paren) {
      auto inner = has_operand ? operand(ob, l.end, pos) : std::optional<Value>(CR);
      if (!inner) return;
      stack.push_back({base, neg, CR});
      CR = *inner;
    } else if (auto v = has_operand ? operand(ob, l.end, pos) : std::nullopt) {
      const Value x = neg ? em.unary_not(em.to_digital(*v, pos), pos) : *v;
      if (auto r = apply(base, CR, x, pos)) {
        CR = *r;
      } else if (auto f = call_function(s, op, {CR, *v}, {}, pos)) {
        CR = *f;
      } else {
        d_.error(pos, "'" + op + "' is not an IL operator rtplc knows");
        return;
      }
    } else {
      if (!d_.has_errors()) d_.error(pos, "'" + op + "' needs an operand");
      return;
    }
  }
  if (!stack.empty() && !d_.has_errors()) d_.error(body.pos, "an IL '(' is never closed");
  for (const auto& [label, arrivals] : pending) {
    (void)arrivals;
    if (!d_.has_errors()) d_.error(body.pos, "jump to " + label + " never reaches its label");
  }
  if (!d_.has_errors()) il_result_ = CR;
}

}  // namespace rtplc::lang::plcopen
