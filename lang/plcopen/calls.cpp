// Function calls and function block instances (see lowering.h): standard
// functions and FBs resolved and lowered by lang/iec's table (docs/iec.md), a
// standard FB's blocks named by instance path; user functions expanded at each
// call, user FBs lowered in their scope.
#include <algorithm>

#include "blocks/int_math.h"
#include "lang/iec/iec_functions.h"
#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {

// ---- functions ----

bool Lowering::is_function(const std::string& up) const {
  if (const iec::IecFunction* f = iec::find_iec(up)) return !f->function_block;
  for (const char* f : {"LEN", "LEFT", "RIGHT", "MID", "CONCAT", "INSERT", "DELETE", "REPLACE", "FIND", "TO_STRING", "TO_WSTRING"}) {
    if (up == f) return true;
  }
  // A conversion lang/iec does not have (STRING_TO_INT): call_function says so.
  if (up.find("_TO_") != std::string::npos) return true;
  const Pou* p = proj_.pou(up);
  return p && p->type == PouType::kFunction;
}

namespace {
// The wider of two integer types, either of which may be unknown (the first on a tie).
std::optional<iec::IecType> wider(std::optional<iec::IecType> a, std::optional<iec::IecType> b) {
  if (!a || !b) return a ? a : b;
  return iec::type_info(*b).bits > iec::type_info(*a).bits ? b : a;
}

// The operand type of an overloaded standard function, from what the importer
// knows of its arguments: BOOL, an integer variable's type (the widest when
// they differ; LINT when only literals say it), else REAL.
iec::IecType operand_type(const iec::IecFunction& f, const std::vector<std::optional<Value>>& args) {
  bool any = false, all_digital = true, all_integer = true;
  std::optional<iec::IecType> known, time;
  bool one_time_type = true;
  for (size_t k = 0; k < args.size(); ++k) {
    if (!args[k] || !iec::iec_input_sets_type(f, k)) continue;
    all_digital = all_digital && args[k]->digital;
    all_integer = all_integer && !args[k]->digital && args[k]->integer;
    known = wider(known, args[k]->int_type);
    one_time_type = one_time_type && args[k]->time_type && (!any || time == args[k]->time_type);
    time = args[k]->time_type;
    any = true;
  }
  if (!any) return iec::IecType::kReal;
  if (all_digital) return iec::IecType::kBool;
  if (one_time_type) return *time;  // TO_DINT(t): t's TIME, DATE, TOD or DT
  if (!all_integer) return iec::IecType::kReal;
  return known ? *known : iec::IecType::kLint;
}

// Puts arguments at their formal input's position (a positional one at the
// next free place); false after an error about `what`.
bool place_args(const iec::IecFunction& f, const std::vector<Value>& args,
                const std::vector<std::string>& formals, std::vector<std::optional<Value>>& placed,
                const std::string& what, DiagnosticList& d, SourcePos pos) {
  size_t positional = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string formal = i < formals.size() ? formals[i] : "";
    int k = -1;
    if (formal.empty()) {
      while (positional < placed.size() && placed[positional]) ++positional;
      k = static_cast<int>(positional);
    } else {
      k = iec::iec_input_index(f, formal);
    }
    const auto at = static_cast<size_t>(k);
    if (k < 0 || (!f.extensible && at >= f.inputs.size())) {
      if (formal.empty()) {
        d.error(pos, what + " takes " + std::to_string(f.inputs.size()) + " argument" +
                         (f.inputs.size() == 1 ? "" : "s") + ", found " +
                         std::to_string(args.size()));
      } else {
        d.error(pos, what + " has no input '" + formal + "'");
      }
      return false;
    }
    if (placed.size() <= at) placed.resize(at + 1);
    placed[at] = args[i];
  }
  return true;
}
}  // namespace

std::vector<Value> Lowering::lower_iec(const iec::IecFunction& f, const std::string& prefix,
                                       const std::vector<std::optional<Value>>& args,
                                       SourcePos pos) {
  // The importer's values are block names, resolved at the end (a value may
  // come from a block made later); lang/iec works by index. Each argument
  // enters as an external operand and the blocks it appended are handed to
  // our emitter by name.
  for (const auto& a : args) {
    if (a && a->str) {
      d_.error(pos, f.name + " does not take a STRING (docs/st.md, \"Strings\", lists what does)");
      return {};
    }
  }
  std::vector<std::string> arg_names;
  for (const auto& a : args) arg_names.push_back(a ? em_.ref(*a, pos) : std::string());
  const size_t first = out_.blocks.size();
  iec::Emitter ie(out_, prefix, pos);
  ie.set_matiec_conversions(semantics_ == EditorSemantics::kMatiec);
  iec::IecCall call;
  call.type = operand_type(f, args);
  std::vector<size_t> slot_arg;
  for (size_t k = 0; k < args.size(); ++k) {
    if (!args[k]) {
      call.inputs.push_back(iec::kUnconnected);
      continue;
    }
    call.inputs.push_back(ie.external(args[k]->digital ? Kind::kDigital : Kind::kAnalog));
    slot_arg.push_back(k);
  }
  const auto outs = f.lower(f, ie, call);
  auto name_of = [&](uint32_t producer) {
    if (!iec::Emitter::is_external(producer)) return out_.blocks[producer].name;
    return arg_names[slot_arg[iec::Emitter::external_slot(producer)]];
  };
  em_.adopt(first, name_of);
  if (!outs) {
    d_.error(pos, outs.error());
    return {};
  }
  const iec::IecType t = iec::iec_result_type(f, call.type);
  std::vector<Value> r;
  for (uint32_t o : *outs) {
    if (o == iec::kUnconnected) {  // an output left out (none is: every one is wanted)
      r.push_back(constant(0, false));
    } else if (iec::Emitter::is_external(o)) {  // MOVE: the argument itself
      r.push_back(*args[slot_arg[iec::Emitter::external_slot(o)]]);
    } else {
      Value v;
      v.ref = out_.blocks[o].name;
      v.digital = ie.kind_of(o) == Kind::kDigital;
      v.integer = !v.digital && iec::type_info(t).integer;
      if (v.integer) v.int_type = t;
      // A conversion's or date function's result (typed: its type is its own);
      // a sum, choice or bound of one time type keeps it (TO_DINT(t1 + t2)).
      static const char* const kKeeps[] = {"ADD", "MAX", "MIN", "LIMIT", "SEL", "MUX", "MOVE"};
      const bool keeps = std::any_of(std::begin(kKeeps), std::end(kKeeps), [&](const char* n) { return f.name == n; }) ||
                         (f.name == "SUB" && t == iec::IecType::kTime);
      if ((f.typed || keeps) && !v.digital && iec::time_grid(t) != 0) v.time_type = t;
      r.push_back(v);
    }
  }
  return r;
}

bool Lowering::is_in_out(const Var* fb, const std::string& function, const std::string& formal) const {
  if (formal.empty()) return false;
  if (fb) {
    if (fb->role != Var::Role::kUserFb) return false;
    auto it = fb->fb->vars.find(upper(formal));
    return it != fb->fb->vars.end() && it->second->role == Var::Role::kInOut;
  }
  const Pou* p = proj_.pou(function);
  if (!p || p->type != PouType::kFunction) return false;
  const Variable* d = p->var(formal);
  return d && d->section == VarSection::kInOut;
}

// Binds each (formal, caller's variable) to the VAR_IN_OUT of `scope`.
static void bind_in_outs(Scope& scope, const std::string& callee,
                         const std::vector<std::pair<std::string, Var*>>& inouts, DiagnosticList& d, SourcePos pos) {
  for (const auto& [formal, var] : inouts) {
    auto it = scope.vars.find(upper(formal));
    if (it == scope.vars.end() || it->second->role != Var::Role::kInOut) {
      d.error(pos, callee + " has no VAR_IN_OUT '" + formal + "'");
      continue;
    }
    // (a VAR_IN_OUT has no storage: its declaration says what it takes)
    const BaseType want = it->second->decl->type.base;
    const bool p_str = want == BaseType::kString || want == BaseType::kWString, p_wide = want == BaseType::kWString;
    if (var != nullptr && (p_str || var->str) && (p_str != var->str || p_wide != var->wide)) {
      auto kind = [](bool str, bool wide) { return std::string(!str ? "a number" : wide ? "a WSTRING" : "a STRING"); };
      d.error(pos, callee + "'s VAR_IN_OUT '" + formal + "' is " + kind(p_str, p_wide) + ", and this call passes " +
                       kind(var->str, var->wide) + " ('" + var->decl->name + "')");
      continue;
    }
    it->second->alias = var;
  }
  // Every VAR_IN_OUT needs the caller's variable, named at the call (not
  // later, at its first use inside the callee's body).
  for (const Variable& decl : scope.pou->vars) {
    if (decl.section != VarSection::kInOut) continue;
    const bool given = std::any_of(inouts.begin(), inouts.end(),
                                   [&](const auto& io) { return upper(io.first) == upper(decl.name); });
    if (!given) {
      d.error(pos, callee + " has VAR_IN_OUT '" + decl.name + "', and this call passes no variable for it: pass one (" +
                       decl.name + " := a_variable)");
    }
  }
}

std::optional<Value> Lowering::call_function(Scope& s, const std::string& name, std::vector<Value> args,
                                             std::vector<std::string> formals, SourcePos pos,
                                             const std::vector<std::pair<std::string, Var*>>& inouts,
                                             const std::vector<std::pair<std::string, Var*>>& wholes) {
  const std::string up = upper(name);
  const Pou* user = proj_.pou(up);
  if (user && user->type == PouType::kFunction) {
    if (++call_depth_ > kMaxNesting) {
      d_.error(pos, "function calls nested deeper than " + std::to_string(kMaxNesting) + " (recursion?)");
      --call_depth_;
      return constant(0, false);
    }
    auto sc = make_scope(*user, s.path + "." + user->name + "()" + em_.fresh(""), call_depth_);
    // The result variable carries the function's name.
    auto rv_decl = std::make_unique<Variable>();
    rv_decl->name = user->name;
    rv_decl->type = *user->return_type;
    Variable* rdecl = rv_decl.get();
    owned_decls_.push_back(std::move(rv_decl));
    auto rv = make_var(*rdecl, sc->path + "." + user->name, call_depth_, true);
    all_vars_.push_back(rv.get());
    sc->vars.emplace(upper(user->name), std::move(rv));
    bind_in_outs(*sc, "function '" + user->name + "'", inouts, d_, pos);
    for (const auto& [formal, src] : wholes) {
      auto it = sc->vars.find(upper(formal));
      if (it != sc->vars.end()) assign_whole(*it->second, *src, pos);
    }
    std::vector<Var*> inputs;
    for (const Variable& d : user->vars) {
      if (d.section == VarSection::kInput) inputs.push_back(sc->vars[upper(d.name)].get());
    }
    for (size_t i = 0; i < args.size(); ++i) {
      Var* target = nullptr;
      if (i < formals.size() && !formals[i].empty()) {
        auto it = sc->vars.find(upper(formals[i]));
        if (it == sc->vars.end() || it->second->decl->section != VarSection::kInput) {
          d_.error(pos, "function '" + user->name + "' has no input '" + formals[i] + "'");
          continue;
        }
        target = it->second.get();
      } else if (i < inputs.size()) {
        target = inputs[i];
      } else {
        d_.error(pos, "function '" + user->name + "' takes " + std::to_string(inputs.size()) + " inputs");
        break;
      }
      assign(*target, args[i], pos);
    }
    Scope& ref = *sc;
    function_scopes_.push_back(std::move(sc));
    auto saved = before_read;  // the function's names are its own, not the caller's
    before_read = nullptr;
    lower_body(ref);
    Value result = read(*ref.vars[upper(user->name)], pos);
    before_read = saved;
    --call_depth_;
    return result;
  }
  if (auto r = call_string_function(up, args, formals, pos)) {
    if (!inouts.empty() || !wholes.empty()) {
      d_.error(pos, name + " takes no variable of its own for '" + (inouts.empty() ? wholes : inouts)[0].first + "'");
    }
    return r;
  }
  const iec::IecFunction* f = iec::find_iec(up);
  if (!f && up.find("_TO_") != std::string::npos) {
    d_.error(pos, "conversion " + name + " names a type rtplc does not have");
    return constant(0, false);
  }
  if (!f || f->function_block) return std::nullopt;
  if (!inouts.empty() || !wholes.empty()) {
    d_.error(pos, name + " takes no variable of its own for '" + (inouts.empty() ? wholes : inouts)[0].first + "'");
    return constant(0, false);
  }
  std::vector<std::optional<Value>> placed;
  if (!place_args(*f, args, formals, placed, name, d_, pos)) return constant(0, false);
  size_t given = 0;
  for (const auto& a : placed) given += a ? 1u : 0u;
  // An extensible function called with one argument (Beremiz writes
  // `OR(x)` for a block left with one input) is that argument, as MatIEC
  // compiles it: its C function folds the inputs it is given, one here.
  // (ADD, MUL, MAX and MIN of a BOOL are type errors there, as with two.)
  const bool logic = up == "AND" || up == "OR" || up == "XOR";
  const bool arith = up == "ADD" || up == "MUL" || up == "MAX" || up == "MIN";
  if (f->extensible && given == 1 && placed.size() == 1 && placed[0] && !placed[0]->str &&
      (logic || (arith && !placed[0]->digital))) {
    return *placed[0];
  }
  if (given < f->min_inputs || given != placed.size()) {
    d_.error(pos, name + " takes " + (f->extensible ? "at least " : "") +
                      std::to_string(f->min_inputs) + " argument" +
                      (f->min_inputs == 1 ? "" : "s") + ", found " + std::to_string(given));
    return constant(0, false);
  }
  const std::vector<Value> outs = lower_iec(*f, em_.fresh(s.path), placed, pos);
  if (outs.empty()) return constant(0, false);
  return outs[0];
}

// ---- operators ----

Value Lowering::operate(BinOp op, const Value& a, const Value& b, SourcePos pos) {
  if (a.str || b.str) return em_.binary(op, a, b, pos);  // compares strings, or says why not
  if (a.is_const && b.is_const) {
    Value r = em_.binary(op, a, b, pos);
    if ((op == BinOp::kAdd || op == BinOp::kSub) && a.time_type && a.time_type == b.time_type &&
        *a.time_type == iec::IecType::kTime) {
      r.time_type = a.time_type;  // T#1s + T#2s is a TIME
    }
    // Folded in the operands' integer type as the task would compute it:
    // wrapped (4000000000 * 3 in UDINT is 3410065408), the product exact.
    const std::optional<iec::IecType> t = wider(a.int_type, b.int_type);
    const bool arith = op == BinOp::kAdd || op == BinOp::kSub || op == BinOp::kMul || op == BinOp::kDiv;
    if (r.is_const && r.integer && t && arith && iec::type_info(*t).integer) {
      const iec::IecTypeInfo& ti = iec::type_info(*t);
      const double m = int_math::type_modulus(ti.bits), half = int_math::type_half(ti.bits, ti.is_signed);
      r.k = op == BinOp::kMul ? int_math::wrapped_product(a.k, b.k, m, half) : int_math::wrap_whole(r.k, m, half);
      r.int_type = t;
    }
    return r;
  }
  static constexpr const char* kName[] = {"ADD", "SUB", "MUL", "DIV", "MOD", "EXPT", "AND", "OR",
                                          "XOR", "EQ",  "NE",  "LT",  "LE",  "GT",  "GE"};
  const iec::IecFunction* f = iec::find_iec(kName[static_cast<size_t>(op)]);
  const std::vector<Value> outs = lower_iec(*f, em_.fresh("op"), {a, b}, pos);
  if (outs.empty()) return constant(0, op >= BinOp::kEq);
  return outs[0];
}

Value Lowering::operate(const char* iec_name, const Value& a, SourcePos pos) {
  const bool is_not = std::string(iec_name) == "NOT";
  if (a.is_const || (is_not && a.digital)) return is_not ? em_.unary_not(a, pos) : em_.negate(a, pos);
  const std::vector<Value> outs = lower_iec(*iec::find_iec(iec_name), em_.fresh("op"), {a}, pos);
  if (outs.empty()) return constant(0, a.digital);
  return outs[0];
}

// ---- function block instances ----

bool Lowering::fb_output_digital(const Var& v, const std::string& name) const {
  const std::string up = upper(name);
  if (v.role == Var::Role::kUserFb) {
    auto it = v.fb->vars.find(up);
    return it != v.fb->vars.end() && it->second->digital;
  }
  const int k = iec::iec_output_index(*v.std_fb.iec, up);
  return k >= 0 && iec::iec_output_kind(*v.std_fb.iec, static_cast<size_t>(k)) == Kind::kDigital;
}

Value Lowering::fb_output(Var& v, const std::string& name, SourcePos pos) {
  const std::string up = upper(name);
  if (v.role == Var::Role::kUserFb) {
    auto it = v.fb->vars.find(up);
    if (it == v.fb->vars.end()) {
      d_.error(pos, "function block '" + v.fb->pou->name + "' has no variable '" + name + "'");
      return constant(0, false);
    }
    return read_from_outside(*it->second, pos);
  }
  const iec::IecFunction& f = *v.std_fb.iec;
  if (iec::iec_output_index(f, up) < 0) {
    std::string outs;
    for (const char* o : f.outputs) outs += (outs.empty() ? "" : " ") + std::string(o);
    d_.error(pos, v.std_fb.type + " has no output '" + name + "' (it has " + outs + ")");
    return constant(0, false);
  }
  if (auto g = gathered_.find(&v); g != gathered_.end() && g->second.size() > gathered_floor_[&v]) {
    d_.error(pos, "'" + v.decl->name + "." + up + "' is read after a call of '" + v.decl->name +
                      "' inside the IF or CASE that calls it in several branches; read it after the END_IF or END_CASE");
    return constant(0, false);
  }
  Value r;
  r.ref = v.path + "." + up;  // made by the call; read before it: last cycle's
  r.digital = fb_output_digital(v, up);
  r.integer = up == "CV";
  if (up == "ET" || up == "PT") r.time_type = iec::IecType::kTime;  // a timer's: TO_DINT(t.ET) is TIME_TO_DINT
  if (!v.std_fb.called) pending_outputs_.push_back(PendingOutput{&v, up, pos});
  return r;
}

// The path of a standard function block instance `s` holds (in a member, an
// element or an instance inside it), or "" when it holds none.
static std::string standard_fb_inside(const Scope& s);
static std::string standard_fb_inside(const Var& v) {
  if (v.role == Var::Role::kStdFb) return v.path;
  if ((v.role == Var::Role::kUserFb || v.role == Var::Role::kStruct) && v.fb) return standard_fb_inside(*v.fb);
  for (const auto& e : v.elems) {
    if (std::string p = standard_fb_inside(*e); !p.empty()) return p;
  }
  return "";
}
static std::string standard_fb_inside(const Scope& s) {
  for (const auto& [name, v] : s.vars) {
    if (std::string p = standard_fb_inside(*v); !p.empty()) return p;
  }
  return "";
}

void Lowering::call_fb(Var& v, const std::vector<std::pair<std::string, Value>>& inputs, SourcePos pos,
                       const std::vector<std::pair<std::string, Var*>>& inouts) {
  if (v.role == Var::Role::kStdFb && !inouts.empty()) {
    d_.error(pos, v.std_fb.type + " has no VAR_IN_OUT '" + inouts[0].first + "'");
    return;
  }
  if (v.role == Var::Role::kUserFb) {
    Scope& fb = *v.fb;
    // A second call in the cycle goes on from the first's values (the body is
    // lowered again on the instance's variables as they are now), unless the
    // instance holds a standard function block, whose blocks run once per
    // textual call.
    if (fb.called) {
      if (fb.pou->body.language == BodyLanguage::kSfc) {
        d_.error(pos, "'" + v.decl->name + "' is called a second time here (in this cycle or another branch), and "
                          "its body is an SFC, which evolves once per cycle: call the instance in one place");
        return;
      }
      if (const std::string inner = standard_fb_inside(fb); !inner.empty()) {
        d_.error(pos, "'" + v.decl->name + "' is called twice in one cycle, and it holds the standard function block "
                          "'" + inner + "', which runs once per call site: call the instance once");
        return;
      }
    }
    fb.called = true;
    // VAR_TEMP starts afresh at every call (start_value: its initial value).
    for (auto& [name, var] : fb.vars) {
      if (var->decl != nullptr && var->decl->section == VarSection::kTemp) var->cur.reset();
    }
    bind_in_outs(fb, "function block '" + fb.pou->name + "'", inouts, d_, pos);
    std::vector<Var*> in_order;
    for (const Variable& d : fb.pou->vars) {
      if (d.section == VarSection::kInput) in_order.push_back(fb.vars[upper(d.name)].get());
    }
    size_t positional = 0;
    for (const auto& [formal, value] : inputs) {
      Var* target = nullptr;
      if (!formal.empty()) {
        auto it = fb.vars.find(upper(formal));
        if (it == fb.vars.end() || it->second->decl->section != VarSection::kInput) {
          d_.error(pos, "function block '" + fb.pou->name + "' has no input '" + formal + "'");
          continue;
        }
        target = it->second.get();
      } else if (positional < in_order.size()) {
        target = in_order[positional++];
      } else {
        d_.error(pos, "too many inputs for function block '" + fb.pou->name + "'");
        break;
      }
      assign(*target, value, pos);
    }
    // R_EDGE / F_EDGE inputs: the body reads the edge of what the input holds
    // now, through the instance's own trigger (make_scope).
    for (const Variable& d : fb.pou->vars) {
      if (d.edge == 0) continue;
      auto in = fb.vars.find(upper(d.name));
      auto trig = fb.vars.find(upper(d.name + "$edge"));
      if (in == fb.vars.end() || trig == fb.vars.end()) continue;
      call_fb(*trig->second, {{"CLK", read(*in->second, pos)}}, pos);
      assign(*in->second, fb_output(*trig->second, "Q", pos), pos);
    }
    auto saved = before_read;
    before_read = nullptr;
    lower_body(fb);
    before_read = saved;
    return;
  }
  StdFb& f = v.std_fb;
  if (f.called) {
    d_.error(pos, "'" + v.decl->name + "' is called twice in one cycle; call an instance once (or in exclusive "
                  "branches of one IF or CASE)");
    return;
  }
  std::vector<Value> args;
  std::vector<std::string> formals;
  for (const auto& [formal, value] : inputs) {
    formals.push_back(upper(formal));
    args.push_back(value);
  }
  std::vector<std::optional<Value>> placed;
  if (!place_args(*f.iec, args, formals, placed, f.type, d_, pos)) return;
  if (auto g = gathered_.find(&v); g != gathered_.end()) {
    g->second.push_back(GatheredCall{active(pos), std::move(placed)});
    return;
  }
  f.called = true;
  lower_std_fb(v, active(pos), std::move(placed), pos);
}

void Lowering::begin_gathered(Var& v) { gathered_[&v]; }

void Lowering::end_gathered(Var& v, SourcePos pos) {
  gathered_floor_.erase(&v);
  auto g = gathered_.find(&v);
  if (g == gathered_.end()) return;
  std::vector<GatheredCall> calls = std::move(g->second);
  gathered_.erase(g);
  if (calls.empty()) return;  // every branch calling it was a constant FALSE
  v.std_fb.called = true;
  if (calls.size() == 1) {
    lower_std_fb(v, calls[0].run, std::move(calls[0].placed), pos);
    return;
  }
  // run = any branch called it; each input = the one of the branch taken
  // (an input a call leaves out keeps its value, as an FB input does).
  Value run = calls[0].run;
  size_t n = 0;
  for (size_t c = 0; c < calls.size(); ++c) {
    if (c > 0) run = em_.binary(BinOp::kOr, run, calls[c].run, pos);
    n = std::max(n, calls[c].placed.size());
  }
  std::vector<std::optional<Value>> merged(n);
  for (size_t k = 0; k < n; ++k) {
    const std::string formal = k < v.std_fb.iec->inputs.size() ? v.std_fb.iec->inputs[k] : "IN" + std::to_string(k + 1);
    std::optional<Value> x;
    for (size_t c = calls.size(); c-- > 0;) {
      if (k >= calls[c].placed.size() || !calls[c].placed[k]) continue;
      const Value& a = *calls[c].placed[k];
      if (!x) {
        // Innermost: the held value itself when no call that gives it runs.
        Value self;
        self.ref = v.path + ".$in." + formal;
        self.digital = a.digital;
        self.integer = a.integer;
        x = em_.select(calls[c].run, a, self, pos);
      } else {
        x = em_.select(calls[c].run, a, *x, pos);
      }
    }
    merged[k] = x;
  }
  lower_std_fb(v, run, std::move(merged), pos);
}

void Lowering::lower_std_fb(Var& v, const Value& run, std::vector<std::optional<Value>> placed, SourcePos pos) {
  const StdFb& f = v.std_fb;
  if (run.is_const && run.k != 0) {
    // Called every cycle. Each output is a block named `instance.OUTPUT`:
    // reads before the call find it later in the cycle (last cycle's value),
    // and hot swap keeps its state.
    const size_t first = out_.blocks.size();
    const std::vector<Value> outs = lower_iec(*f.iec, v.path, placed, pos);
    // In the order the blocks run (CTU's CV before its Q): `rtplc sim` traces them so.
    for (size_t i = first; i < out_.blocks.size(); ++i) {
      const std::string& n = out_.blocks[i].name;
      for (const Value& o : outs) {
        if (o.ref == n) {
          produced_.push_back(n);
          break;
        }
      }
    }
    return;
  }
  // Called only in the cycles `run` holds (under IF, CASE, a conditional IL
  // path, EN, an SFC action, an event task). An FB that is not called keeps
  // its variables: its inputs are held at their last call's values, so its
  // machine sees no edge and no new preset meanwhile, and each output shows
  // its value from the last call. A timer's elapsed time still runs on while
  // it is not called, as in MatIEC and CODESYS, where TON compares the
  // current time with the time its IN rose.
  for (size_t k = 0; k < placed.size(); ++k) {
    // A constant too: TON(IN := TRUE) must see IN rise at its first call.
    if (!placed[k]) continue;
    const std::string formal = k < f.iec->inputs.size() ? f.iec->inputs[k] : "IN" + std::to_string(k + 1);
    placed[k] = hold(run, *placed[k], v.path + ".$in." + formal, pos);
  }
  const std::vector<Value> raw = lower_iec(*f.iec, v.path + ".$call", placed, pos);
  for (size_t i = 0; i < raw.size() && i < f.iec->outputs.size(); ++i) {
    const std::string n = v.path + "." + f.iec->outputs[i];
    hold(run, raw[i], n, pos);
    produced_.push_back(n);
  }
}

Value Lowering::hold(const Value& run, const Value& x, const std::string& name, SourcePos pos) {
  Value self;
  self.ref = name;  // appended below: read here, it is last cycle's value
  self.digital = x.digital;
  self.integer = x.integer;
  self.int_type = x.int_type;
  em_.copy_as(em_.select(run, x, self, pos), name, pos);
  return self;
}

void Lowering::push_path(const Value& cond, bool negated) {
  path_.push_back(PathCond{em_.to_digital(cond, SourcePos{}), negated, std::nullopt});
}

void Lowering::pop_path() { path_.pop_back(); }

Value Lowering::active(SourcePos pos) {
  if (path_.empty()) return constant(1, true);
  for (size_t i = 0; i < path_.size(); ++i) {
    PathCond& p = path_[i];
    if (p.conj) continue;
    const Value c = p.negated ? em_.unary_not(p.cond, pos) : p.cond;
    p.conj = i == 0 ? c : em_.binary(BinOp::kAnd, *path_[i - 1].conj, c, pos);
  }
  return *path_.back().conj;
}

bool Lowering::finish() {
  if (globals_) finalize(*globals_);
  for (auto& [fb, v] : eno_vars_) finalize_var(*v);
  for (const EdgeMemory& m : edge_memories_) em_.copy_as(m.value, m.name, m.pos);
  for (const PendingOutput& po : pending_outputs_) {
    const std::string n = po.fb->path + "." + po.name;
    if (std::find(produced_.begin(), produced_.end(), n) != produced_.end()) continue;
    if (!po.fb->std_fb.called)
      d_.error(po.pos, "'" + po.fb->decl->name + "." + po.name + "' is read but '" + po.fb->decl->name +
                           "' is never called");
  }
  if (d_.has_errors()) return false;
  return em_.finish();
}

}  // namespace rtplc::lang::plcopen
