// ST statements -> blocks by if-conversion (docs/plcopen.md, "ST"): both
// branches of an IF are computed every cycle and each variable's value after
// the IF is sel(cond, then, else) (`amux` for numbers, and/or for BOOL). CASE
// is a chain of IFs; FOR with constant bounds (at most 1,000 runs) is
// unrolled. RETURN, EXIT and CONTINUE become conditions: what follows them
// runs under NOT the condition that they ran. WHILE, REPEAT and any other FOR
// are real loops on the executor's control flow (docs/st.md, "Loops"): each
// variable the loop may write gets a home (a var block) set before the loop,
// read by the body, set again at the end of each iteration, and read after
// the loop. A user FB
// called inside a branch has its variables merged like the caller's (kept
// when not called); a standard FB called there sees its inputs, and shows
// its outputs, as they were at its last call (Lowering::call_fb).
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {
namespace {
constexpr int kMaxUnroll = 1000;
}

void var_leaves(Var& v, std::vector<Var*>& out, std::set<const Var*>& seen) {
  switch (v.role) {
    case Var::Role::kArray:
      for (auto& e : v.elems) var_leaves(*e, out, seen);
      return;
    case Var::Role::kStruct:
    case Var::Role::kUserFb:
      if (v.fb) {
        for (auto& [name, m] : v.fb->vars) var_leaves(*m, out, seen);
      }
      return;
    case Var::Role::kInOut:
      if (v.alias) var_leaves(*v.alias, out, seen);
      return;
    case Var::Role::kStdFb:
      return;
    default:
      if (seen.insert(&v).second) out.push_back(&v);
  }
}

Var* Lowering::in_out_argument(Scope& s, const Expr& e, const std::string& formal, SourcePos pos) {
  if (e.kind != Expr::Kind::kName) {
    d_.error(pos, "VAR_IN_OUT '" + formal + "' needs a variable, not an expression");
    return nullptr;
  }
  Var* v = resolve_static(s, e.name, e.args, pos);
  if (v && (v->role == Var::Role::kUserFb || v->role == Var::Role::kStdFb || v->role == Var::Role::kStruct ||
            v->role == Var::Role::kArray)) {
    d_.error(pos, "VAR_IN_OUT '" + formal + "': passing a whole function block, structure or array is not supported yet");
    return nullptr;
  }
  return v;
}

Value Lowering::eval(Scope& s, const Expr& e) {
  switch (e.kind) {
    case Expr::Kind::kLiteral: {
      if (e.is_string) return string_constant(e.text, e.wide);
      Value v = constant(e.k, e.is_bool);
      v.time_type = e.time_type;
      v.integer = !e.is_bool && !e.is_time && !e.is_real && e.k == std::floor(e.k);
      return v;
    }
    case Expr::Kind::kName:
      // a, fb1.Q, p.x, a[i], an enumeration value (Mode#Run, Run)
      return load(s, e.name, e.args, e.pos);
    case Expr::Kind::kNot:
      return operate("NOT", eval(s, *e.args[0]), e.pos);
    case Expr::Kind::kNeg:
      return operate("NEG", eval(s, *e.args[0]), e.pos);
    case Expr::Kind::kBinary: {
      Value a = eval(s, *e.args[0]);
      Value b = eval(s, *e.args[1]);
      return operate(e.op, a, b, e.pos);
    }
    case Expr::Kind::kCall: {
      if (e.en_guarded) {
        // SEL(EN, 0, f(...)) keeps f's value, not its writes: a function that
        // writes through VAR_IN_OUT or VAR_EXTERNAL would write with EN false.
        if (const Pou* f = proj_.pou(upper(e.name)); f && f->type == PouType::kFunction) {
          for (const Variable& v : f->vars) {
            if (v.section == VarSection::kInOut || v.section == VarSection::kExternal) {
              d_.error(e.pos, "EN on a call of function '" + f->name + "', which has " +
                                  (v.section == VarSection::kInOut ? "VAR_IN_OUT" : "VAR_EXTERNAL") + " '" + v.name +
                                  "', is not supported yet inside an expression (its writes would happen with EN "
                                  "false); call it as a statement: " + f->name + "(EN := ...);");
              return constant(0, false);
            }
          }
        }
      }
      std::vector<Value> args;
      std::vector<std::string> formals;
      std::vector<std::pair<std::string, Var*>> inouts, wholes;
      for (size_t i = 0; i < e.args.size(); ++i) {
        const std::string& f = i < e.arg_names.size() ? e.arg_names[i] : std::string();
        if (is_in_out(nullptr, e.name, f)) {
          if (Var* v = in_out_argument(s, *e.args[i], f, e.args[i]->pos)) inouts.emplace_back(f, v);
          continue;
        }
        if (whole_parameter(e.name, f)) {
          const Expr& a = *e.args[i];
          Var* v = a.kind == Expr::Kind::kName && a.args.empty() ? whole_var(s, a.name) : nullptr;
          if (!v) d_.error(a.pos, "'" + f + "' is a structure or array: pass a variable of its type");
          else wholes.emplace_back(f, v);
          continue;
        }
        args.push_back(eval(s, *e.args[i]));
        formals.push_back(f);
      }
      if (d_.has_errors()) return constant(0, false);
      auto r = call_function(s, e.name, args, formals, e.pos, inouts, wholes);
      if (!r) {
        Var* v = lookup(s, e.name, e.pos, false);
        if (v && (v->role == Var::Role::kStdFb || v->role == Var::Role::kUserFb))
          d_.error(e.pos, "'" + e.name + "' is a function block instance: call it as a statement, then read its outputs");
        else
          d_.error(e.pos, "'" + e.name + "' is not a function rtplc knows");
        return constant(0, false);
      }
      return *r;
    }
  }
  return constant(0, false);
}

namespace {

struct StLowerer {
  Lowering& L;
  Scope& s;

  // How control left a statement list: the conditions (this cycle) under
  // which it ran RETURN, EXIT or CONTINUE. Constant FALSE when it cannot.
  struct Flow {
    Value ret = constant(0, true), exit = constant(0, true), cont = constant(0, true);
  };
  static bool never(const Value& v) { return v.is_const && v.k == 0; }
  Value either(const Value& a, const Value& b, SourcePos pos) {
    if (never(a)) return b;
    if (never(b)) return a;
    return L.em().binary(BinOp::kOr, a, b, pos);
  }

  // The statements from `from` on. After one that may leave (RETURN, EXIT,
  // CONTINUE under some condition), the rest runs by if-conversion under
  // NOT that condition.
  Flow block(const Block& b, size_t from = 0, size_t to = static_cast<size_t>(-1)) {
    to = std::min(to, b.size());
    if (from == 0 && to == b.size() &&
        std::any_of(b.begin(), b.end(), [](const auto& st) { return st->kind == Stmt::Kind::kLabel; })) {
      return region(b);
    }
    for (size_t i = from; i < to; ++i) {
      if (L.diags().has_errors()) return {};
      const Flow f = statement(*b[i]);
      const SourcePos pos = b[i]->pos;
      const Value leave = either(either(f.ret, f.exit, pos), f.cont, pos);
      if (never(leave)) continue;
      if (leave.is_const || i + 1 == to) return f;  // always leaves, or nothing follows
      Flow rest;
      branch(L.em().unary_not(leave, pos), pos, [&] { rest = block(b, i + 1, to); }, [] {});
      // The rest's reasons count only where it ran: computed by if-conversion
      // whatever `leave` was, they may be TRUE in a cycle that left here.
      return pick(leave, f, rest, pos);
    }
    return {};
  }

  Flow pick(const Value& c, const Flow& t, const Flow& e, SourcePos pos) {
    Emitter& em = L.em();
    const Value d = em.to_digital(c, pos);
    return Flow{em.select(d, t.ret, e.ret, pos), em.select(d, t.exit, e.exit, pos), em.select(d, t.cont, e.cont, pos)};
  }

  // Runs `then` or `otherwise` by if-conversion; `cond` is already evaluated.
  template <class Then, class Else>
  void branch(const Value& cond, SourcePos pos, Then then, Else otherwise) {
    Emitter& em = L.em();
    const Value c = em.to_digital(cond, pos);
    if (c.is_const) {  // constant condition: only the live branch
      if (c.k != 0) then();
      else otherwise();
      return;
    }
    const auto before = L.save();
    L.push_path(c, false);
    then();
    L.pop_path();
    const auto after_then = L.save();
    L.restore(before);
    L.push_path(c, true);
    otherwise();
    L.pop_path();
    const auto after_else = L.save();
    // Merge: every variable either branch assigned.
    std::vector<std::optional<Value>> merged = after_else;
    L.restore(before);
    std::vector<Var*> vars = all_vars();
    for (size_t i = 0; i < vars.size(); ++i) {
      const std::optional<Value>& t = i < after_then.size() ? after_then[i] : std::nullopt;
      const std::optional<Value>& e = i < after_else.size() ? after_else[i] : std::nullopt;
      if (!t && !e) continue;
      const bool same = t && e && t->is_const == e->is_const &&
                        (t->is_const ? t->k == e->k : t->ref == e->ref);
      if (same) continue;
      Var& v = *vars[i];
      // A branch that left it alone keeps the value from before the IF.
      const Value tv = t ? *t : L.read(v, pos);
      const Value ev = e ? *e : L.read(v, pos);
      Value m = em.select(c, tv, ev, pos);
      m.integer = v.integer;
      merged[i] = m;
    }
    L.restore(merged);
  }

  std::vector<Var*> all_vars() { return L.vars_for_merge(); }

  // The caller's structure or array an argument names (`fb(p := q)`).
  Var* whole_argument(const Expr& e, const std::string& formal, SourcePos pos) {
    Var* v = e.kind == Expr::Kind::kName && e.args.empty() ? L.whole_var(s, e.name) : nullptr;
    if (!v) L.diags().error(pos, "'" + formal + "' is a structure or array: pass a variable of its type");
    return v;
  }

  // How many times each instance is called as a statement in `b` (a FOR
  // body's calls count twice: it may run more than once).
  static void count_calls(const Block& b, std::map<std::string, int>& n, int weight = 1) {
    for (const auto& st : b) {
      switch (st->kind) {
        case Stmt::Kind::kCall:
          if (st->target_index.empty()) n[upper(st->target)] += weight;
          break;
        case Stmt::Kind::kIf:
          for (const auto& [c, body] : st->branches) count_calls(body, n, weight);
          count_calls(st->else_body, n, weight);
          break;
        case Stmt::Kind::kCase:
          for (const CaseBranch& cb : st->cases) count_calls(cb.body, n, weight);
          count_calls(st->else_body, n, weight);
          break;
        case Stmt::Kind::kFor:
        case Stmt::Kind::kWhile:
        case Stmt::Kind::kRepeat:
          count_calls(st->body, n, 2);
          break;
        default:
          break;
      }
    }
  }

  // The standard FB instances this IF or CASE calls in two or more of its
  // branches, at most once in each: gathered (Lowering::begin_gathered).
  std::vector<Var*> gather(const Stmt& st) {
    std::map<std::string, std::pair<int, int>> seen;  // name -> (branches calling it, most calls in one)
    for (const Block* b : bodies(st)) {
      std::map<std::string, int> n;
      count_calls(*b, n);
      for (const auto& [name, k] : n) {
        auto& e = seen[name];
        e.first += 1;
        e.second = std::max(e.second, k);
      }
    }
    std::vector<Var*> out;
    for (const auto& [name, e] : seen) {
      if (e.first < 2 || e.second > 1) continue;
      Var* v = L.lookup(s, name, st.pos, false);
      if (!v || v->role != Var::Role::kStdFb || v->std_fb.called || L.gathered(*v)) continue;
      L.begin_gathered(*v);
      out.push_back(v);
    }
    return out;
  }

  // `F.ENO := ...` the parser wrote after a call with EN whose target is a
  // function, not an instance: a function keeps no ENO.
  bool eno_of_function(const Stmt& st) {
    return st.eno_of_call && !L.lookup(s, st.target.substr(0, st.target.find_first_of(".[")), st.pos, false);
  }

  Flow statement(const Stmt& st) {
    Emitter& em = L.em();
    switch (st.kind) {
      case Stmt::Kind::kAssign: {
        if (eno_of_function(st)) break;
        if (Var* dst = st.target_index.empty() ? L.whole_var(s, st.target) : nullptr) {
          // A whole structure or array: member by member, from one of its type.
          Var* src = st.value->kind == Expr::Kind::kName && st.value->args.empty() ? L.whole_var(s, st.value->name)
                                                                                  : nullptr;
          if (!src) {
            L.diags().error(st.value->pos, "'" + dst->decl->name + "' is a whole " +
                                               (dst->role == Var::Role::kStruct ? "structure" : "array") +
                                               ": assign a variable of its type, or one member at a time");
            return {};
          }
          L.assign_whole(*dst, *src, st.pos);
          break;
        }
        Value v = L.eval(s, *st.value);
        L.store(s, st.target, st.target_index, v, st.pos);
        break;
      }
      case Stmt::Kind::kReturn: {
        Flow f;
        f.ret = constant(1, true);
        return f;
      }
      case Stmt::Kind::kExit: {
        Flow f;
        f.exit = constant(1, true);
        return f;
      }
      case Stmt::Kind::kContinue: {
        Flow f;
        f.cont = constant(1, true);
        return f;
      }
      case Stmt::Kind::kJump:
        jump(st);
        return {};
      case Stmt::Kind::kLabel:  // only where region() did not cut the list (a CASE branch)
        L.diags().error(st.pos, "a label cannot start a CASE branch's statements ('" + st.target +
                                    ":' reads as a CASE label there)");
        return {};
      case Stmt::Kind::kIf: {
        const std::vector<Var*> g = gather(st);
        if (!g.empty()) {
          if (auto cuts = split_points(st, g)) return split_chain(st, std::move(*cuts), g, nullptr);
        }
        const Flow f = if_chain(st, 0);
        for (Var* v : g) L.end_gathered(*v, st.pos);
        return f;
      }
      case Stmt::Kind::kCase: {
        const std::vector<Var*> g = gather(st);
        const Value sel = L.eval(s, *st.value);
        if (!g.empty()) {
          if (auto cuts = split_points(st, g)) return split_chain(st, std::move(*cuts), g, &sel);
        }
        const Flow f = case_chain(st, sel, 0);
        for (Var* v : g) L.end_gathered(*v, st.pos);
        return f;
      }
      case Stmt::Kind::kFor: {
        // Constant bounds and at most kMaxUnroll runs: unrolled (straight-line
        // code, batched like any other). Anything else is a real loop.
        if (!constant_expr(*st.from) || !constant_expr(*st.to) || (st.by && !constant_expr(*st.by))) {
          return loop(st);
        }
        const Value from = L.eval(s, *st.from), to = L.eval(s, *st.to);
        const Value by = st.by ? L.eval(s, *st.by) : constant(1, false);
        if (!from.is_const || !to.is_const || !by.is_const) return loop(st);
        if (by.k == 0) {
          L.diags().error(st.pos, "FOR with BY 0 never ends");
          return {};
        }
        const double n = std::floor((to.k - from.k) / by.k) + 1;
        if (n > kMaxUnroll) return loop(st);
        Var* iv = L.resolve_static(s, st.target, st.target_index, st.pos);
        if (!iv) return {};
        Flow f;
        f.ret = iterations(st, *iv, from.k, to.k, by.k);
        return f;  // EXIT and CONTINUE end with the loop
      }
      case Stmt::Kind::kWhile:
      case Stmt::Kind::kRepeat:
        return loop(st);
      case Stmt::Kind::kCall: {
        if (!st.target_index.empty()) {
          // An element of an array of FB instances: `t[i](...)` with `i`
          // known only at run time calls the element it names.
          std::vector<Place> ps = L.places(s, st.target, st.target_index, st.pos);
          if (L.diags().has_errors()) return {};
          if (ps.size() > 1 || (ps.size() == 1 && !(ps[0].when.is_const && ps[0].when.k != 0))) {
            indexed_call(st, ps);
            return {};
          }
        }
        Var* fb = st.target_index.empty() && L.is_function(upper(st.target)) &&
                          !L.lookup(s, st.target, st.pos, false)
                      ? nullptr
                      : L.resolve_static(s, st.target, st.target_index, st.pos);
        if (!fb && L.diags().has_errors()) return {};
        if (!fb || (fb->role != Var::Role::kStdFb && fb->role != Var::Role::kUserFb)) {
          // A function called as a statement: its result is dropped.
          std::vector<Value> args;
          std::vector<std::string> formals;
          std::vector<std::pair<std::string, Var*>> inouts, wholes;
          for (const CallArg& a : st.call_args) {
            if (a.output) continue;
            if (L.is_in_out(nullptr, st.target, a.formal)) {
              if (Var* v = L.in_out_argument(s, *a.value, a.formal, a.pos)) inouts.emplace_back(a.formal, v);
              continue;
            }
            if (L.whole_parameter(st.target, a.formal)) {
              if (Var* v = whole_argument(*a.value, a.formal, a.pos)) wholes.emplace_back(a.formal, v);
              continue;
            }
            args.push_back(L.eval(s, *a.value));
            formals.push_back(upper(a.formal));
          }
          if (L.diags().has_errors()) return {};
          if (!L.call_function(s, st.target, args, formals, st.pos, inouts, wholes))
            L.diags().error(st.pos, "'" + st.target + "' is neither a function block instance nor a function");
          return {};
        }
        std::vector<std::pair<std::string, Value>> ins;
        std::vector<std::pair<std::string, Var*>> inouts;
        for (const CallArg& a : st.call_args) {
          if (a.output) continue;
          if (L.is_in_out(fb, "", a.formal)) {
            if (Var* v = L.in_out_argument(s, *a.value, a.formal, a.pos)) inouts.emplace_back(a.formal, v);
          } else if (Var* m = L.whole_member(fb, a.formal)) {
            // A structure or array input: copied in before the call.
            if (Var* v = whole_argument(*a.value, a.formal, a.pos)) L.assign_whole(*m, *v, a.pos);
          } else {
            ins.emplace_back(a.formal, L.eval(s, *a.value));
          }
        }
        if (L.diags().has_errors()) return {};
        L.call_fb(*fb, ins, st.pos, inouts);
        for (const CallArg& a : st.call_args) {
          if (!a.output) continue;
          if (Var* m = L.whole_member(fb, a.formal)) {  // a structure or array output: copied out
            Var* dst = a.target_index.empty() ? L.whole_var(s, a.target) : nullptr;
            if (!dst) {
              L.diags().error(a.pos, "'" + a.formal + "' is a whole structure or array: '=>' needs a variable of its type");
              return {};
            }
            L.assign_whole(*dst, *m, a.pos);
            continue;
          }
          const Value v = L.fb_output(*fb, a.formal, a.pos);
          L.store(s, a.target, a.target_index, v, a.pos);
        }
        (void)em;
        break;
      }
    }
    return {};
  }

  // `a[i](...)` with an index known only at run time: the inputs evaluated
  // once, then each element called under the condition that `i` names it
  // (an IF per element, if-converted like any other: only the element named
  // is called, and a standard FB's state advances only there); an index out
  // of range calls none. Outputs (`Q => x`) are read from the element called.
  void indexed_call(const Stmt& st, const std::vector<Place>& ps) {
    for (const Place& p : ps) {
      if (!p.var || !p.output.empty() || (p.var->role != Var::Role::kStdFb && p.var->role != Var::Role::kUserFb)) {
        L.diags().error(st.pos, "'" + path_text(st.target) + "' is not a function block instance to call");
        return;
      }
    }
    std::vector<std::pair<std::string, Value>> ins;
    for (const CallArg& a : st.call_args) {
      if (a.output) continue;
      if (L.is_in_out(ps[0].var, "", a.formal) || L.whole_member(ps[0].var, a.formal)) {
        L.diags().error(a.pos, "'" + a.formal + "': a VAR_IN_OUT or a whole structure or array is not passed to an "
                                                "element chosen at run time yet; call it with a constant index");
        return;
      }
      ins.emplace_back(a.formal, L.eval(s, *a.value));
    }
    if (L.diags().has_errors()) return;
    for (const Place& p : ps) {
      branch(p.when, st.pos, [&] {
        L.call_fb(*p.var, ins, st.pos);
        for (const CallArg& a : st.call_args) {
          if (!a.output || L.diags().has_errors()) continue;
          if (L.whole_member(p.var, a.formal)) {
            L.diags().error(a.pos, "'" + a.formal + "' is a whole structure or array: not read from an element "
                                                    "chosen at run time yet");
            return;
          }
          L.store(s, a.target, a.target_index, L.fb_output(*p.var, a.formal, a.pos), a.pos);
        }
      }, [] {});
      if (L.diags().has_errors()) return;
    }
  }

  // An expression with no names and no calls: a literal, or operators on them.
  static bool constant_expr(const Expr& e) {
    if (e.kind == Expr::Kind::kName || e.kind == Expr::Kind::kCall) return false;
    for (const auto& a : e.args) {
      if (a && !constant_expr(*a)) return false;
    }
    return true;
  }

  static bool has_call(const Expr& e) {
    if (e.kind == Expr::Kind::kCall) return true;
    for (const auto& a : e.args) {
      if (a && has_call(*a)) return true;
    }
    return false;
  }

  void name_leaves(const std::string& path, SourcePos pos, std::vector<Var*>& out, std::set<const Var*>& seen) {
    const size_t cut = path.find_first_of(".[");
    Var* v = L.lookup(s, path.substr(0, cut), pos, false);
    if (v) var_leaves(*v, out, seen);
  }
  void expr_names(const Expr& e, std::vector<Var*>& out, std::set<const Var*>& seen) {
    if (e.kind == Expr::Kind::kName) name_leaves(e.name, e.pos, out, seen);
    for (const auto& a : e.args) {
      if (a) expr_names(*a, out, seen);
    }
  }

  // What a loop body writes (`written`) and reads (`read`), as variables,
  // over-approximated: an array or structure named with any index counts
  // whole. False, with the error given, for what a loop cannot hold yet.
  bool scan(const Block& b, std::vector<Var*>& written, std::set<const Var*>& ws, std::vector<Var*>& read,
            std::set<const Var*>& rs, bool& returns) {
    for (const auto& st : b) {
      for (const auto& ix : st->target_index) {
        if (ix) expr_names(*ix, read, rs);
      }
      if (st->value) expr_names(*st->value, read, rs);
      for (const auto* e : {st->from.get(), st->to.get(), st->by.get()}) {
        if (e) expr_names(*e, read, rs);
      }
      switch (st->kind) {
        case Stmt::Kind::kAssign:
        case Stmt::Kind::kFor:
          if (eno_of_function(*st)) break;
          name_leaves(st->target, st->pos, written, ws);
          name_leaves(st->target, st->pos, read, rs);
          break;
        case Stmt::Kind::kCall: {
          Var* fb = L.lookup(s, st->target.substr(0, st->target.find_first_of(".[")), st->pos, false);
          // A user function block runs its body inline: its variables are the
          // loop's like any other. A standard one's blocks keep its state and
          // run at each call, each call one step of its machine (an edge, a
          // count), as the standard's bodies do; a timer's time is the cycle's
          // (blocks/executor_body.inc), so calls in one cycle read one time.
          if (fb && (fb->role == Var::Role::kUserFb || fb->role == Var::Role::kArray)) var_leaves(*fb, written, ws);
          for (const CallArg& a : st->call_args) {
            if (a.output) {
              name_leaves(a.target, a.pos, written, ws);
            } else if (a.value) {
              expr_names(*a.value, read, rs);
              // A variable passed as an argument may be a VAR_IN_OUT: written.
              if (a.value->kind == Expr::Kind::kName) name_leaves(a.value->name, a.pos, written, ws);
            }
          }
          break;
        }
        case Stmt::Kind::kReturn:
          returns = true;
          break;
        default:
          break;
      }
      for (const auto& [c, body] : st->branches) {
        if (c) expr_names(*c, read, rs);
        if (!scan(body, written, ws, read, rs, returns)) return false;
      }
      for (const CaseBranch& cb : st->cases) {
        for (const auto& [lo, hi] : cb.labels) {
          if (lo) expr_names(*lo, read, rs);
          if (hi) expr_names(*hi, read, rs);
        }
        if (!scan(cb.body, written, ws, read, rs, returns)) return false;
      }
      if (!scan(st->else_body, written, ws, read, rs, returns)) return false;
      if (!scan(st->body, written, ws, read, rs, returns)) return false;
    }
    return true;
  }

  // A variable's home in a loop (Lowering::make_home), and whose it is.
  struct Home : Lowering::LoopHome {
    Var* var = nullptr;  // nullptr: a flag (RETURN, EXIT, CONTINUE)
  };
  Home make_home(const std::string& stem, bool digital, bool integer, SourcePos pos,
                 std::optional<uint32_t> str_cap = std::nullopt, bool wide = false) {
    Home h;
    static_cast<Lowering::LoopHome&>(h) = L.make_home(stem, digital, integer, pos, str_cap, wide);
    return h;
  }
  void set_home(const Home& h, const Value& v, SourcePos pos) { L.set_home(h, v, pos); }
  // Everything a loop or a labelled list reads or caches, made here in code
  // that always runs: a value first made inside it would be stale after a
  // cycle in which that part did not run (a loop without iterations, a
  // segment a jump skipped).
  void read_ahead(const std::vector<Var*>& read, SourcePos pos) {
    for (Var* v : read) {
      if (v->role == Var::Role::kPlain || v->role == Var::Role::kInput || v->role == Var::Role::kSetpoint) {
        (void)L.read(*v, pos);
      }
    }
  }
  // A home for each plain variable in `written`, holding its value now; from
  // here on it is read there. The homes are entered as the innermost loop's
  // (Lowering::enter_loop: a Put writes into them); the caller leaves it.
  std::vector<Home> home_all(const std::vector<Var*>& written, SourcePos pos) {
    std::vector<Home> homes;
    std::map<const Var*, Lowering::LoopHome> index;
    for (Var* v : written) {
      // A located input the body writes too (MatIEC's: lasts until the next cycle).
      if ((v->role != Var::Role::kPlain && v->role != Var::Role::kInput) || (v->decl && v->decl->constant)) continue;
      const Value before = L.read(*v, pos);
      Home h;
      static_cast<Lowering::LoopHome&>(h) = L.make_home_for(*v, pos);
      h.var = v;
      set_home(h, before, pos);
      v->cur = h.value;
      index[v] = h;
      homes.push_back(std::move(h));
    }
    L.enter_loop(std::move(index));
    return homes;
  }
  // Each home takes its variable's value now (where it differs).
  void sync_homes(const std::vector<Home>& homes, SourcePos pos) {
    std::vector<std::pair<Var*, const Lowering::LoopHome*>> all;
    for (const Home& h : homes) all.emplace_back(h.var, &h);
    L.sync_homes(all, pos);
  }

  // WHILE, REPEAT, and a FOR that is not unrolled, as a loop of the executor:
  //
  //   homes := the values before the loop        (straight-line)
  //   H: [WHILE/FOR: jz (cond AND active) -> X]
  //      body
  //      homes := their values now; [jnz (EXIT or RETURN) -> X]
  //      [FOR: counter := counter + BY] [REPEAT: jnz (UNTIL OR NOT active) -> X]
  //      loop -> H
  //   X: every variable reads its home
  //
  // `active` is the if-conversion's path: a loop inside an IF branch not
  // taken runs no iteration (a REPEAT's one run is discarded by the merge).
  Flow loop(const Stmt& st) {
    Emitter& em = L.em();
    const SourcePos pos = st.pos;
    std::vector<Var*> written, read;
    std::set<const Var*> ws, rs;
    bool returns = false;
    if (!scan(st.body, written, ws, read, rs, returns)) return {};
    Var* iv = nullptr;
    if (st.kind == Stmt::Kind::kFor) {
      iv = L.resolve_static(s, st.target, st.target_index, pos);
      if (!iv) return {};
      L.assign(*iv, L.eval(s, *st.from), pos);
      if (ws.insert(iv).second) written.push_back(iv);
    }
    if (L.diags().has_errors()) return {};
    read_ahead(read, pos);
    const bool guarded = L.conditional();
    const Value active = guarded ? L.active(pos) : constant(1, true);
    // A FOR's TO and BY that read nothing the loop writes (and call nothing)
    // have the same value before every iteration: evaluated once, here.
    std::optional<Value> to_before, by_before;
    if (st.kind == Stmt::Kind::kFor) {
      auto invariant = [&](const Expr& e) {
        if (has_call(e)) return false;
        std::vector<Var*> names;
        std::set<const Var*> seen;
        expr_names(e, names, seen);
        return std::none_of(names.begin(), names.end(), [&](const Var* v) { return ws.count(v) != 0; });
      };
      if (invariant(*st.to)) to_before = L.eval(s, *st.to);
      if (st.by && invariant(*st.by)) by_before = L.eval(s, *st.by);
    }
    const std::vector<Home> homes = home_all(written, pos);
    struct Leave {
      Lowering& l;
      ~Leave() { l.leave_loop(); }
    } leave{L};
    std::optional<Home> ret;
    if (returns) {
      ret = make_home(s.path + ".$return", true, false, pos);
      set_home(*ret, constant(0, true), pos);
    }
    const auto head = static_cast<uint32_t>(em.size());
    std::vector<size_t> exits;
    Value by = constant(1, false);
    if (st.kind != Stmt::Kind::kRepeat) {
      Value c;
      if (st.kind == Stmt::Kind::kWhile) {
        c = em.to_digital(L.eval(s, *st.value), pos);
      } else {
        const Value to = to_before ? *to_before : L.eval(s, *st.to);
        if (st.by) by = by_before ? *by_before : L.eval(s, *st.by);
        const Value i = L.read(*iv, pos);
        if (by.is_const && by.k == 0) {
          L.diags().error(pos, "FOR with BY 0 never ends");
          return {};
        }
        // As the C a MatIEC project compiles to: TO and BY are evaluated again
        // before each iteration, and a positive BY counts up to TO, any other
        // down to it.
        // (Only the test a constant BY needs is made.)
        if (by.is_const) {
          c = em.binary(by.k > 0 ? BinOp::kLe : BinOp::kGe, i, to, pos);
        } else {
          const Value up = em.binary(BinOp::kLe, i, to, pos), down = em.binary(BinOp::kGe, i, to, pos);
          c = em.select(em.binary(BinOp::kGt, by, constant(0, false), pos), up, down, pos);
        }
      }
      if (guarded) c = em.binary(BinOp::kAnd, c, active, pos);
      exits.push_back(em.emit_flow("jz", em.fresh(s.path + ".$while"), pos, {em.ref(c, pos)}, 0));
    }
    const Flow f = block(st.body);
    if (L.diags().has_errors()) return {};
    sync_homes(homes, pos);
    if (ret && !never(f.ret)) set_home(*ret, f.ret, pos);
    const Value stop = either(f.ret, f.exit, pos);
    if (!never(stop)) {
      exits.push_back(em.emit_flow("jnz", em.fresh(s.path + ".$exit"), pos, {em.ref(em.to_digital(stop, pos), pos)}, 0));
    }
    if (st.kind == Stmt::Kind::kFor) {
      L.assign(*iv, L.operate(BinOp::kAdd, L.read(*iv, pos), by, pos), pos);
      for (const Home& h : homes) {
        if (h.var == iv) set_home(h, L.read(*iv, pos), pos);
      }
    } else if (st.kind == Stmt::Kind::kRepeat) {
      Value u = em.to_digital(L.eval(s, *st.value), pos);
      if (guarded) u = em.binary(BinOp::kOr, u, em.unary_not(active, pos), pos);
      exits.push_back(em.emit_flow("jnz", em.fresh(s.path + ".$until"), pos, {em.ref(u, pos)}, 0));
    }
    if (L.diags().has_errors()) return {};
    em.emit_flow("loop", em.fresh(s.path + ".$loop"), pos, {}, head);
    const auto after = static_cast<uint32_t>(em.size());
    for (size_t x : exits) em.block(x).target = after;
    for (const Home& h : homes) h.var->cur = h.value;
    Flow out;
    if (ret) out.ret = ret->value;  // EXIT and CONTINUE end with the loop
    return out;
  }

  // Labels and JMP (docs/st.md, "Jumps"). A statement list holding labels is
  // a region: cut at its labels into segments, each lowered as any list. Every
  // variable the list may write gets a home (as in a loop), set at the end of
  // each segment and before each JMP to one of its labels, and read after
  // each label, so a label's code sees the same values whether control fell
  // through or jumped. A forward JMP is a jnz (jmp) to its label's first run;
  // a backward one is a counted loop instruction, under a jz on the path when
  // the JMP sits in an IF branch. A segment that may RETURN, EXIT or CONTINUE
  // leaves the region by a real jump, its reasons in flag homes read at the
  // end: the if-conversion that guards what follows such a statement never
  // reaches past a label, where control may arrive by a jump.
  struct Region {
    std::map<std::string, size_t> labels;                // label -> its index in the list
    std::map<std::string, uint32_t> placed;              // label -> its first run, once lowered
    std::map<std::string, std::vector<size_t>> pending;  // label -> the forward jumps to it
    std::vector<Home> homes;
    size_t gathering = 0;  // standard FB instances gathered around the region
  };
  std::vector<Region*> regions_;
  std::map<std::string, SourcePos> labels_seen_;  // every label of the body: each name once

  // ---- an IF or CASE lowered in two passes around its gathered calls ----
  // The state-machine idiom calls one standard FB in several branches and
  // reads its outputs in the same branch (`1: t(IN := TRUE, PT := T#2s); IF
  // t.Q THEN state := 2; END_IF;`). Its one call (end_gathered) needs every
  // branch's inputs, and a branch's reads after its call need that call's
  // outputs. The branches are exclusive and if-converted, so no branch sees
  // another's statements: the first pass lowers each branch up to its last
  // call of a gathered FB (its prefix, from the state before the IF), keeping
  // the variables' state at that point; the FB runs once on the gathered
  // inputs; the second pass lowers each branch's rest from its kept state,
  // and merges the branches as one IF. A branch's prefix holds only
  // assignments, calls, IF and CASE (no loop, jump, label, RETURN, EXIT or
  // CONTINUE), and it calls the gathered FBs only as its own statements.
  struct Split {
    const Stmt* stmt = nullptr;
    std::vector<size_t> cut;                                // per branch (the ELSE last): statements in its prefix
    std::vector<std::vector<std::optional<Value>>> state;  // per branch: the variables after its prefix
    std::vector<Value> conds;                               // per branch but the ELSE: its condition
  };
  Split* split_ = nullptr;

  // Assignments, calls, and IF and CASE of them: no loop, jump, label,
  // RETURN, EXIT or CONTINUE anywhere in `b`.
  static bool flow_free(const Block& b) {
    for (const auto& st : b) {
      if (!flow_free_stmt(*st)) return false;
    }
    return true;
  }
  static bool flow_free_stmt(const Stmt& x) {
    if (x.kind == Stmt::Kind::kAssign || x.kind == Stmt::Kind::kCall) return true;
    if (x.kind != Stmt::Kind::kIf && x.kind != Stmt::Kind::kCase) return false;
    for (const Block* b : bodies(x)) {
      if (!flow_free(*b)) return false;
    }
    return true;
  }

  // The branch bodies of an IF or CASE, the ELSE last.
  static std::vector<const Block*> bodies(const Stmt& st) {
    std::vector<const Block*> out;
    for (const auto& [c, body] : st.branches) out.push_back(&body);
    for (const CaseBranch& cb : st.cases) out.push_back(&cb.body);
    out.push_back(&st.else_body);
    return out;
  }

  // Each branch's prefix length, or nullopt when the two passes cannot be used.
  std::optional<std::vector<size_t>> split_points(const Stmt& st, const std::vector<Var*>& gathered) {
    std::set<std::string> names;
    for (const Var* v : gathered) names.insert(upper(v->decl->name));
    std::vector<size_t> cuts;
    for (const Block* b : bodies(st)) {
      size_t cut = 0;
      std::map<std::string, int> top;
      if (has_jumps(*b)) return std::nullopt;  // a jump keeps the one call at the END_IF (region())
      for (size_t j = 0; j < b->size(); ++j) {
        const Stmt& x = *(*b)[j];
        if (x.kind == Stmt::Kind::kCall && x.target_index.empty() && names.count(upper(x.target))) {
          cut = j + 1;
          ++top[upper(x.target)];
        }
      }
      std::map<std::string, int> all;
      count_calls(*b, all);
      for (const std::string& n : names) {
        if (all[n] != top[n]) return std::nullopt;  // called inside a nested statement too
      }
      for (size_t j = 0; j < cut; ++j) {
        if (!flow_free_stmt(*(*b)[j])) return std::nullopt;
      }
      cuts.push_back(cut);
    }
    return cuts;
  }
  static bool has_jumps(const Block& b) {
    for (const auto& st : b) {
      if (st->kind == Stmt::Kind::kLabel || st->kind == Stmt::Kind::kJump) return true;
      for (const auto& [c, body] : st->branches) {
        if (has_jumps(body)) return true;
      }
      for (const CaseBranch& cb : st->cases) {
        if (has_jumps(cb.body)) return true;
      }
      if (has_jumps(st->else_body) || has_jumps(st->body)) return true;
    }
    return false;
  }

  // CASE branch i's condition: the selector matches one of its labels.
  Value case_cond(const Stmt& st, const Value& sel, size_t i) {
    Emitter& em = L.em();
    Value cond = constant(0, true);
    for (const auto& [lo, hi] : st.cases[i].labels) {
      const Value a = L.eval(s, *lo);
      Value m = hi ? em.binary(BinOp::kAnd, em.binary(BinOp::kGe, sel, a, lo->pos),
                               em.binary(BinOp::kLe, sel, L.eval(s, *hi), hi->pos), lo->pos)
                   : em.binary(BinOp::kEq, sel, a, lo->pos);
      cond = em.binary(BinOp::kOr, cond, m, lo->pos);
    }
    return cond;
  }

  // The IF (sel null) or CASE `st` in two passes (Split above); ends the
  // gathering of `gathered`.
  Flow split_chain(const Stmt& st, std::vector<size_t> cuts, const std::vector<Var*>& gathered, const Value* sel) {
    Emitter& em = L.em();
    Split sp;
    sp.stmt = &st;
    sp.cut = std::move(cuts);
    const std::vector<const Block*> bs = bodies(st);
    sp.state.resize(bs.size());
    const auto pre = L.save();
    // Pass 1: each live branch's prefix under the path branch() would give it.
    size_t pushed = 0;
    bool dead = false;
    for (size_t i = 0; i + 1 < bs.size(); ++i) {
      Value c = sel ? case_cond(st, *sel, i) : L.eval(s, *st.branches[i].first);
      c = em.to_digital(c, sel ? st.pos : st.branches[i].first->pos);
      sp.conds.push_back(c);
      if (dead || (c.is_const && c.k == 0)) continue;
      if (!c.is_const) L.push_path(c, false);
      for (Var* v : gathered) L.gathered_branch_starts(*v);
      block(*bs[i], 0, sp.cut[i]);
      sp.state[i] = L.save();
      if (!c.is_const) {
        L.pop_path();
        L.push_path(c, true);  // the branches after it: NOT c
        ++pushed;
      } else {
        dead = true;  // a constant TRUE: nothing after it runs
      }
      L.restore(pre);
    }
    if (!dead) {
      for (Var* v : gathered) L.gathered_branch_starts(*v);
      block(*bs.back(), 0, sp.cut.back());
      sp.state.back() = L.save();
    }
    for (; pushed > 0; --pushed) L.pop_path();
    L.restore(pre);
    if (L.diags().has_errors()) return {};
    for (Var* v : gathered) L.end_gathered(*v, st.pos);
    // Pass 2: the rests, merged as one IF.
    Split* outer = split_;
    split_ = &sp;
    const Flow f = sel ? case_chain(st, *sel, 0) : if_chain(st, 0);
    split_ = outer;
    return f;
  }

  // Branch k's statements: all of them, or (in a split's second pass) the
  // rest after its prefix, from the state its prefix left.
  Flow branch_body(const Stmt& st, const Block& b, size_t k) {
    if (!split_ || split_->stmt != &st) return block(b);
    L.restore(split_->state[k]);
    return block(b, split_->cut[k]);
  }

  // Whether `b` may EXIT or CONTINUE a loop around it (not one inside it).
  static void loop_leaves(const Block& b, bool& exit, bool& cont) {
    for (const auto& st : b) {
      if (st->kind == Stmt::Kind::kExit) exit = true;
      if (st->kind == Stmt::Kind::kContinue) cont = true;
      if (st->kind == Stmt::Kind::kFor || st->kind == Stmt::Kind::kWhile || st->kind == Stmt::Kind::kRepeat) {
        continue;
      }
      for (const auto& [c, body] : st->branches) loop_leaves(body, exit, cont);
      for (const CaseBranch& cb : st->cases) loop_leaves(cb.body, exit, cont);
      loop_leaves(st->else_body, exit, cont);
    }
  }

  Flow region(const Block& b) {
    Emitter& em = L.em();
    const SourcePos pos = b.front()->pos;
    Region r;
    for (size_t i = 0; i < b.size(); ++i) {
      if (b[i]->kind != Stmt::Kind::kLabel) continue;
      // (The same label lowered again is an unrolled FOR's next iteration.)
      const auto [it, fresh] = labels_seen_.emplace(b[i]->target, b[i]->pos);
      if (!fresh && (it->second.line != b[i]->pos.line || it->second.col != b[i]->pos.col)) {
        L.diags().error(b[i]->pos, "label '" + b[i]->target + "' is already defined at line " +
                                       std::to_string(it->second.line));
        return {};
      }
      r.labels[b[i]->target] = i;
    }
    std::vector<Var*> written, read;
    std::set<const Var*> ws, rs;
    bool returns = false, exits = false, conts = false;
    if (!scan(b, written, ws, read, rs, returns)) return {};
    loop_leaves(b, exits, conts);
    // The path's condition too is made before any segment a jump may skip.
    read_ahead(read, pos);
    if (L.conditional()) (void)L.active(pos);
    r.homes = home_all(written, pos);
    std::optional<Home> flag[3];  // RETURN, EXIT, CONTINUE
    const bool may[3] = {returns, exits, conts};
    const char* const what[3] = {"$return", "$exit", "$continue"};
    for (int k = 0; k < 3; ++k) {
      if (!may[k]) continue;
      flag[k] = make_home(s.path + ".$jump" + what[k], true, false, pos);
      set_home(*flag[k], constant(0, true), pos);
    }
    r.gathering = L.gathering();
    regions_.push_back(&r);
    struct Leave {
      StLowerer& t;
      ~Leave() {
        t.regions_.pop_back();
        t.L.leave_loop();
      }
    } leave{*this};
    std::vector<size_t> to_end;
    size_t begin = 0;
    for (size_t i = 0; i <= b.size(); ++i) {
      if (i < b.size() && b[i]->kind != Stmt::Kind::kLabel) continue;
      const Flow f = block(b, begin, i);
      if (L.diags().has_errors()) return {};
      const SourcePos at = i < b.size() ? b[i]->pos : b.back()->pos;
      sync_homes(r.homes, at);
      const Value out = either(either(f.ret, f.exit, at), f.cont, at);
      if (!never(out)) {
        const Value* reason[3] = {&f.ret, &f.exit, &f.cont};
        for (int k = 0; k < 3; ++k) {
          if (flag[k] && !never(*reason[k])) set_home(*flag[k], *reason[k], at);
        }
        if (i < b.size()) {
          to_end.push_back(em.emit_flow("jnz", em.fresh(s.path + ".$leave"), at, {em.ref(em.to_digital(out, at), at)}, 0));
        }
      }
      if (i == b.size()) break;
      const auto here = static_cast<uint32_t>(em.size());
      r.placed[b[i]->target] = here;
      for (size_t x : r.pending[b[i]->target]) em.block(x).target = here;
      for (const Home& h : r.homes) h.var->cur = h.value;
      begin = i + 1;
    }
    const auto end = static_cast<uint32_t>(em.size());
    for (size_t x : to_end) em.block(x).target = end;
    for (const Home& h : r.homes) h.var->cur = h.value;
    Flow f;
    if (flag[0]) f.ret = flag[0]->value;
    if (flag[1]) f.exit = flag[1]->value;
    if (flag[2]) f.cont = flag[2]->value;
    return f;
  }

  void jump(const Stmt& st) {
    Emitter& em = L.em();
    const SourcePos pos = st.pos;
    Region* r = nullptr;
    for (auto it = regions_.rbegin(); it != regions_.rend() && !r; ++it) {
      if ((*it)->labels.count(st.target) != 0) r = *it;
    }
    if (!r) {
      L.diags().error(pos, "JMP " + st.target + ": no label '" + st.target +
                               "' in this statement list or one around it (a jump may leave an IF, CASE or loop, "
                               "never enter one)");
      return;
    }
    if (L.gathering() > r->gathering) {
      L.diags().error(pos, "JMP " + st.target + " inside an IF or CASE that calls one standard function block "
                               "instance in several branches is not supported yet (the call runs at its END_IF)");
      return;
    }
    const Value c = L.conditional() ? L.active(pos) : constant(1, true);
    sync_homes(r->homes, pos);
    const std::string name = em.fresh(s.path + ".$jmp_" + st.target);
    if (auto it = r->placed.find(st.target); it != r->placed.end()) {
      // Backward: the only way back, so counted against the task's loop_budget.
      std::optional<size_t> skip;
      if (!(c.is_const && c.k != 0)) {
        skip = em.emit_flow("jz", name + "$skip", pos, {em.ref(em.to_digital(c, pos), pos)}, 0);
      }
      em.emit_flow("loop", name, pos, {}, it->second);
      if (skip) em.block(*skip).target = static_cast<uint32_t>(em.size());
      return;
    }
    const size_t x = c.is_const && c.k != 0 ? em.emit_flow("jmp", name, pos, {}, 0)
                                            : em.emit_flow("jnz", name, pos, {em.ref(em.to_digital(c, pos), pos)}, 0);
    r->pending[st.target].push_back(x);
  }

  // The unrolled iterations of a FOR from `i` on; the condition under which
  // one of them ran RETURN. After an iteration that may EXIT (or RETURN), the
  // rest run under NOT that condition; CONTINUE ends only its own iteration.
  Value iterations(const Stmt& st, Var& iv, double i, double to, double by) {
    for (; by > 0 ? i <= to : i >= to; i += by) {
      Value k = constant(i, false);
      k.integer = true;
      L.assign(iv, k, st.pos);
      const Flow f = block(st.body);
      if (L.diags().has_errors()) return constant(0, true);
      const Value stop = either(f.ret, f.exit, st.pos);
      if (never(stop)) continue;
      if (stop.is_const) return f.ret;
      Value rest = constant(0, true);
      const double next = i + by;
      branch(L.em().unary_not(stop, st.pos), st.pos, [&] { rest = iterations(st, iv, next, to, by); }, [] {});
      // The later iterations' RETURN counts only when they ran (see block()).
      return L.em().select(L.em().to_digital(stop, st.pos), f.ret, rest, st.pos);
    }
    // As a loop that is not unrolled: the counter ends one step past TO.
    Value k = constant(i, false);
    k.integer = true;
    L.assign(iv, k, st.pos);
    return constant(0, true);
  }

  Flow if_chain(const Stmt& st, size_t i) {
    if (i >= st.branches.size()) return branch_body(st, st.else_body, i);
    const bool split = split_ && split_->stmt == &st;
    const Value c = split ? split_->conds[i] : L.eval(s, *st.branches[i].first);
    const SourcePos pos = st.branches[i].first->pos;
    Flow t, e;
    branch(c, pos, [&] { t = branch_body(st, st.branches[i].second, i); }, [&] { e = if_chain(st, i + 1); });
    return pick(c, t, e, pos);
  }

  Flow case_chain(const Stmt& st, const Value& sel, size_t i) {
    if (i >= st.cases.size()) return branch_body(st, st.else_body, i);
    const bool split = split_ && split_->stmt == &st;
    const Value cond = split ? split_->conds[i] : case_cond(st, sel, i);
    Flow t, e;
    branch(cond, st.pos, [&] { t = branch_body(st, st.cases[i].body, i); }, [&] { e = case_chain(st, sel, i + 1); });
    return pick(cond, t, e, st.pos);
  }
};

}  // namespace

void Lowering::lower_st(Scope& s, const Block& b) {
  StLowerer st{*this, s, {}, {}};
  st.block(b);
}

void Lowering::lower_st_guarded(Scope& s, const Block& b, const Value& cond, SourcePos pos) {
  guarded(cond, pos, [&] { lower_st(s, b); });
}

void Lowering::guarded(const Value& cond, SourcePos pos, const std::function<void()>& f) {
  Scope none;
  StLowerer st{*this, none, {}, {}};
  st.branch(cond, pos, [&] { f(); }, [] {});
}

}  // namespace rtplc::lang::plcopen
