// Function calls and function block instances (see lowering.h): the standard
// functions as IEC blocks, user functions expanded at each call, standard FBs
// as stateful blocks named by instance path, user FBs lowered in their scope.
#include <algorithm>
#include <cctype>
#include <cmath>

#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {

// ---- functions ----

bool Lowering::is_function(const std::string& up) const {
  static const char* const kStd[] = {
      "ADD", "SUB", "MUL", "DIV", "MOD", "EXPT", "AND", "OR", "XOR", "NOT", "GT", "GE", "EQ", "NE",
      "LT", "LE", "MOVE", "ABS", "SQRT", "SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN", "MAX", "MIN",
      "LIMIT", "SEL", "MUX", "TRUNC", "LN", "LOG", "EXP"};
  for (const char* n : kStd) {
    if (up == n) return true;
  }
  if (up.find("_TO_") != std::string::npos) return true;
  const Pou* p = proj_.pou(up);
  return p && p->type == PouType::kFunction;
}

namespace {
// Orders formal arguments the way the standard function takes them.
int formal_rank(const std::string& f) {
  if (f == "G" || f == "K" || f == "MN") return 0;
  if (f == "IN" || f == "IN0" || f == "IN1") return f == "IN1" ? 2 : 1;
  if (f == "MX") return 1000;
  if (f.size() > 2 && f.compare(0, 2, "IN") == 0) {
    int n = 0;
    for (size_t i = 2; i < f.size() && std::isdigit(static_cast<unsigned char>(f[i])); ++i) n = n * 10 + (f[i] - '0');
    return n + 1;
  }
  return 500;
}
}  // namespace

std::optional<Value> Lowering::call_function(Scope& s, const std::string& name, std::vector<Value> args,
                                             std::vector<std::string> formals, SourcePos pos) {
  const std::string up = upper(name);
  // Put formal arguments in the standard's order (IN1, IN2... / G, IN0, IN1 / MN, IN, MX).
  bool all_formal = !formals.empty();
  for (const std::string& f : formals) all_formal = all_formal && !f.empty();
  const Pou* user = proj_.pou(up);
  if (all_formal && !(user && user->type == PouType::kFunction)) {
    std::vector<size_t> idx(args.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::stable_sort(idx.begin(), idx.end(),
                     [&](size_t a, size_t b) { return formal_rank(formals[a]) < formal_rank(formals[b]); });
    std::vector<Value> sorted;
    for (size_t i : idx) sorted.push_back(args[i]);
    args = std::move(sorted);
  }
  auto want = [&](size_t n) {
    if (args.size() == n) return true;
    d_.error(pos, name + " takes " + std::to_string(n) + " argument" + (n == 1 ? "" : "s") + ", found " +
                      std::to_string(args.size()));
    return false;
  };
  auto chain = [&](BinOp op) -> Value {
    if (args.size() < 2) {
      d_.error(pos, name + " takes at least 2 arguments");
      return constant(0, false);
    }
    Value r = em_.binary(op, args[0], args[1], pos);
    for (size_t i = 2; i < args.size(); ++i) r = em_.binary(op, r, args[i], pos);
    return r;
  };
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
  if (up == "ADD") return chain(BinOp::kAdd);
  if (up == "MUL") return chain(BinOp::kMul);
  if (up == "AND") return chain(BinOp::kAnd);
  if (up == "OR") return chain(BinOp::kOr);
  if (up == "XOR") return chain(BinOp::kXor);
  if (up == "SUB") return want(2) ? em_.binary(BinOp::kSub, args[0], args[1], pos) : constant(0, false);
  if (up == "DIV") return want(2) ? em_.binary(BinOp::kDiv, args[0], args[1], pos) : constant(0, false);
  if (up == "MOD") return want(2) ? em_.binary(BinOp::kMod, args[0], args[1], pos) : constant(0, false);
  if (up == "EXPT") return want(2) ? em_.binary(BinOp::kExpt, args[0], args[1], pos) : constant(0, false);
  if (up == "NOT") return want(1) ? em_.unary_not(args[0], pos) : constant(0, true);
  if (up == "MOVE") return want(1) ? args[0] : constant(0, false);
  static const std::pair<const char*, BinOp> kCompare[] = {
      {"GT", BinOp::kGt}, {"GE", BinOp::kGe}, {"EQ", BinOp::kEq},
      {"NE", BinOp::kNe}, {"LT", BinOp::kLt}, {"LE", BinOp::kLe}};
  for (const auto& [n, op] : kCompare) {
    if (up != n) continue;
    if (args.size() < 2 || (op == BinOp::kNe && args.size() != 2)) {
      want(2);
      return constant(0, true);
    }
    Value r = em_.binary(op, args[0], args[1], pos);  // GT(a, b, c) = a > b AND b > c
    for (size_t i = 2; i < args.size(); ++i)
      r = em_.binary(BinOp::kAnd, r, em_.binary(op, args[i - 1], args[i], pos), pos);
    return r;
  }
  static const std::pair<const char*, const char*> kMath[] = {
      {"ABS", "abs"}, {"SQRT", "sqrt"}, {"SIN", "sin"}, {"COS", "cos"}, {"TAN", "tan"},
      {"ASIN", "asin"}, {"ACOS", "acos"}, {"ATAN", "atan"}, {"TRUNC", "trunc"},
      {"LN", "ln"}, {"LOG", "log"}, {"EXP", "exp"}};
  for (const auto& [n, blk] : kMath) {
    if (up != n) continue;
    if (!want(1)) return constant(0, false);
    Value r = em_.call1(blk, args[0], pos);
    r.integer = up == "ABS" ? args[0].integer : up == "TRUNC";
    return r;
  }
  if (up == "MAX" || up == "MIN") {
    if (args.size() < 2) {
      want(2);
      return constant(0, false);
    }
    const char* blk = up == "MAX" ? "max" : "min";
    Value r = em_.call2(blk, args[0], args[1], pos);
    for (size_t i = 2; i < args.size(); ++i) r = em_.call2(blk, r, args[i], pos);
    return r;
  }
  if (up == "LIMIT") {
    if (!want(3)) return constant(0, false);
    return em_.call2("max", args[0], em_.call2("min", args[1], args[2], pos), pos);
  }
  if (up == "SEL") {
    if (!want(3)) return constant(0, false);
    return em_.select(args[0], args[2], args[1], pos);
  }
  if (up == "MUX") {
    if (args.size() < 3) {
      d_.error(pos, "MUX takes K and at least 2 inputs");
      return constant(0, false);
    }
    Value r = args.back();  // K out of range: the last input (MatIEC keeps the last too)
    for (size_t i = args.size() - 1; i-- > 1;) {
      r = em_.select(em_.binary(BinOp::kEq, args[0], constant(static_cast<double>(i - 1), false), pos), args[i], r, pos);
    }
    return r;
  }
  const size_t to = up.find("_TO_");
  if (to != std::string::npos) {
    if (!want(1)) return constant(0, false);
    const std::string from_t = up.substr(0, to), to_t = up.substr(to + 4);
    const auto ft = elementary_type(from_t), tt = elementary_type(to_t);
    if (!tt || !ft) {
      d_.error(pos, "conversion " + name + " names a type rtplc does not have");
      return constant(0, false);
    }
    if (*tt == BaseType::kBool) return em_.to_digital(args[0], pos);
    Value r = em_.to_analog(args[0], pos);
    // TIME converts to and from numbers in milliseconds (as lang/iec does);
    // TIME values themselves are seconds.
    if (*ft == BaseType::kTime && *tt != BaseType::kTime) r = em_.binary(BinOp::kMul, r, constant(1000, false), pos);
    if (*tt == BaseType::kTime && *ft != BaseType::kTime) r = em_.binary(BinOp::kDiv, r, constant(1000, false), pos);
    const bool from_real = *ft == BaseType::kReal || *ft == BaseType::kLreal || *ft == BaseType::kTime;
    if (integer_type(*tt) && from_real && !r.is_const) {
      r = em_.call1("round", r, pos);  // IEC rounds REAL to an integer (halves away from 0)
    } else if (integer_type(*tt) && from_real && r.is_const) {
      r = constant(std::round(r.k), false);
    }
    r.integer = integer_type(*tt);
    return r;
  }
  return std::nullopt;
}

// ---- function block instances ----

bool Lowering::fb_output_digital(const Var& v, const std::string& name) const {
  const std::string up = upper(name);
  if (v.role == Var::Role::kUserFb) {
    auto it = v.fb->vars.find(up);
    return it != v.fb->vars.end() && it->second->digital;
  }
  return up == "Q" || up == "Q1" || up == "QU" || up == "QD";
}

Value Lowering::fb_output(Var& v, const std::string& name, SourcePos pos) {
  const std::string up = upper(name);
  if (v.role == Var::Role::kUserFb) {
    auto it = v.fb->vars.find(up);
    if (it == v.fb->vars.end()) {
      d_.error(pos, "function block '" + v.fb->pou->name + "' has no variable '" + name + "'");
      return constant(0, false);
    }
    return read(*it->second, pos);
  }
  static const std::pair<const char*, const char*> kOutputs[] = {
      {"R_TRIG", "Q"}, {"F_TRIG", "Q"}, {"SR", "Q1"}, {"RS", "Q1"}, {"TON", "Q ET"}, {"TOF", "Q ET"},
      {"TP", "Q ET"},  {"CTU", "Q CV"}, {"CTD", "Q CV"}, {"CTUD", "QU QD CV"}};
  bool known = false;
  for (const auto& [t, outs] : kOutputs) {
    if (v.std_fb.type != t) continue;
    std::string list = std::string(" ") + outs + " ";
    known = list.find(" " + up + " ") != std::string::npos;
    if (!known) {
      d_.error(pos, v.std_fb.type + " has no output '" + name + "' (it has " + outs + ")");
      return constant(0, false);
    }
  }
  Value r;
  r.ref = v.path + "." + up;  // made by the call; read before it: last cycle's
  r.digital = fb_output_digital(v, up);
  r.integer = up == "CV";
  if (!v.std_fb.called) pending_outputs_.push_back(PendingOutput{&v, up, pos});
  return r;
}

void Lowering::call_fb(Var& v, const std::vector<std::pair<std::string, Value>>& inputs, SourcePos pos) {
  if (conditional_depth > 0 && v.role == Var::Role::kStdFb) {
    // A user FB's variables are if-converted with the branch (kept when it is
    // not called); a standard FB's timer or counter state cannot be frozen.
    d_.error(pos, "a call of standard function block " + v.std_fb.type + " '" + v.decl->name +
                      "' inside IF, CASE or a conditional IL path is not supported yet (call it "
                      "unconditionally and use its inputs)");
    return;
  }
  if (v.role == Var::Role::kUserFb) {
    Scope& fb = *v.fb;
    if (fb.called) {
      d_.error(pos, "'" + v.decl->name + "' is called twice in one cycle; rtplc gives each call its own state, so call an instance once");
      return;
    }
    fb.called = true;
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
    auto saved = before_read;
    before_read = nullptr;
    lower_body(fb);
    before_read = saved;
    return;
  }
  StdFb& f = v.std_fb;
  if (f.called) {
    d_.error(pos, "'" + v.decl->name + "' is called twice in one cycle; call an instance once");
    return;
  }
  f.called = true;
  std::map<std::string, Value> in;
  size_t positional = 0;
  static const std::pair<const char*, const char*> kInputs[] = {
      {"R_TRIG", "CLK"}, {"F_TRIG", "CLK"}, {"SR", "S1 R"}, {"RS", "S R1"}, {"TON", "IN PT"},
      {"TOF", "IN PT"}, {"TP", "IN PT"}, {"CTU", "CU R PV"}, {"CTD", "CD LD PV"},
      {"CTUD", "CU CD R LD PV"}};
  std::vector<std::string> names;
  for (const auto& [t, list] : kInputs) {
    if (f.type != t) continue;
    std::string l = list, w;
    for (char c : l + " ") {
      if (c == ' ') {
        names.push_back(w);
        w.clear();
      } else {
        w += c;
      }
    }
  }
  for (const auto& [formal, value] : inputs) {
    std::string n = upper(formal);
    if (n.empty()) n = positional < names.size() ? names[positional++] : "";
    if (std::find(names.begin(), names.end(), n) == names.end()) {
      d_.error(pos, f.type + " has no input '" + formal + "'");
      continue;
    }
    in[n] = value;
  }
  const std::string& p = v.path;
  auto input = [&](const char* n, bool digital) {
    auto it = in.find(n);
    if (it == in.end()) return constant(0, digital);
    return digital ? em_.to_digital(it->second, pos) : em_.to_analog(it->second, pos);
  };
  auto ref = [&](const char* n, bool digital) { return em_.ref(input(n, digital), pos); };
  // Each output is a block named `instance.OUTPUT`: reads before the call find
  // it later in the cycle (last cycle's value), and hot swap keeps its state.
  auto out = [&](const char* n, const char* blk, std::vector<std::string> ins, std::vector<double> prm = {}) {
    em_.emit(blk, p + "." + n, pos, std::move(ins), std::move(prm));
    produced_.push_back(p + "." + n);
  };
  const std::string& t = f.type;
  if (t == "R_TRIG" || t == "F_TRIG") {
    out("Q", t == "R_TRIG" ? "rtrig" : "ftrig", {ref("CLK", true)});
  } else if (t == "SR") {
    out("Q1", "sr", {ref("S1", true), ref("R", true)});
  } else if (t == "RS") {
    out("Q1", "rs", {ref("S", true), ref("R1", true)});
  } else if (t == "TON" || t == "TOF" || t == "TP") {
    std::string blk = t == "TON" ? "ton" : t == "TOF" ? "tof" : "tp";
    const std::string x = ref("IN", true), pt = ref("PT", false);
    out("Q", blk.c_str(), {x, pt});
    out("ET", (blk + "_et").c_str(), {x, pt});
  } else if (t == "CTU") {
    const std::string pv = ref("PV", false);
    out("CV", "ctu", {ref("CU", true), ref("R", true)});
    out("Q", "ge", {p + ".CV", pv});
  } else if (t == "CTD") {
    out("CV", "ctd", {ref("CD", true), ref("LD", true), ref("PV", false)});
    out("Q", "le", {p + ".CV", em_.ref(constant(0, false), pos)});
  } else if (t == "CTUD") {
    const Value r = input("R", true);
    const std::string pv = ref("PV", false);
    em_.emit("updn", p + ".step", pos, {ref("CU", true), ref("CD", true)});
    const Value load = em_.binary(BinOp::kOr, r, input("LD", true), pos);
    const Value pv_or_0 = em_.select(r, constant(0, false), input("PV", false), pos);
    out("CV", "ctud", {p + ".step", em_.ref(load, pos), em_.ref(pv_or_0, pos)});
    out("QU", "ge", {p + ".CV", pv});
    out("QD", "le", {p + ".CV", em_.ref(constant(0, false), pos)});
  }
}

bool Lowering::finish() {
  if (globals_) finalize(*globals_);
  for (const auto& [v, mem] : edge_memories_) em_.copy_as(v, mem, SourcePos{});
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
