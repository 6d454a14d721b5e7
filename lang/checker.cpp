// Checking and macro expansion (spec fbd-language.md: macros, ids, kinds, errors).
//
// Names are resolved after the whole program is expanded, because a reference may
// point at a block further down the file (a one-cycle delay). Each macro call
// gets its own scope whose formals are aliases of the caller's arguments, and the
// call's result id is an alias of the macro's RETURN id inside that scope; an
// input is resolved by following aliases until a real block is reached.
//
// F and D ids (M and N inside a macro) are separate names: F5 and D5 may both
// exist. The letter is part of the name and fixes the kind, so "F used where D is
// needed" is decided by the letter and a reference always finds a block of the
// kind it names.
#include "lang/checker.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "common/capacities.h"
#include "common/text.h"

namespace rtplc::lang {
namespace {

bool is_analog_letter(char l) { return l == 'F' || l == 'M'; }
bool is_value_letter(char l) { return l == 'F' || l == 'D' || l == 'M' || l == 'N'; }
Kind letter_kind(char l) { return is_analog_letter(l) ? Kind::kAnalog : Kind::kDigital; }
char top_letter(Kind k) { return k == Kind::kAnalog ? 'F' : 'D'; }
char macro_letter(Kind k) { return k == Kind::kAnalog ? 'M' : 'N'; }

uint64_t id_key(Kind k, uint32_t n) { return (uint64_t{k == Kind::kDigital} << 32) | n; }


struct Binding {
  enum class What : uint8_t { kBlock, kAlias, kPoison };
  What what = What::kBlock;
  uint32_t flat = 0;      // kBlock
  int alias_scope = -1;   // kAlias
  Ref alias_ref;          // kAlias
  SourcePos pos;          // where the name was introduced
  bool is_formal = false;
};

struct ParamBinding {
  bool known = false;  // false while dry-checking an uncalled macro
  double value = 0;
};

struct Scope {
  int parent = -1;
  bool top = true;
  std::string prefix;  // name prefix for blocks of this expansion ("F10.")
  uint32_t call_line = 0;
  SourcePos call_pos;
  std::string macro;   // macro name, for notes
  std::unordered_map<uint64_t, Binding> ids;
  std::unordered_map<uint32_t, ParamBinding> params;
};

struct PendingInput {
  uint32_t block;
  uint32_t slot;
  int scope;
  Ref ref;
};

struct ChannelUse {
  uint32_t line;
  std::string label;
};

class Checker {
 public:
  Checker(const Program& prog, DiagnosticList& d) : prog_(prog), diags_(d) {}

  CheckedProgram run() {
    index_macros();
    out_.period = prog_.has_stime ? prog_.stime : kDefaultPeriod;
    out_.period_from_stime = prog_.has_stime;
    out_.stime_pos = prog_.stime_pos;

    scopes_.push_back(Scope{});  // top level
    expand_body(prog_.body, 0);
    resolve_all();
    check_channels();
    check_unused();

    // Macros nobody calls are still checked, with unknown parameter values.
    for (const MacroDef& def : prog_.defs) {
      if (expanded_.count(def.name) == 0 && valid_def_.count(def.name) != 0) dry_check(def);
    }
    for (const MacroDecl& d : prog_.decls) {
      if (defs_.count(d.name) == 0 && called_.count(d.name) == 0) {
        diags_.warning(d.pos, "MACRO " + d.name + " is declared but never defined or used",
                       d.name_length);
      }
    }
    if (!prog_.has_stime && !prog_.body.empty()) {
      diags_.note(SourcePos{}, "no stime(...) in the program: the task period defaults to " +
                                   format_number(kDefaultPeriod) + " s");
    }
    if (out_.blocks.size() > kMaxBlocks) {
      diags_.error(SourcePos{}, "the program expands to " + std::to_string(out_.blocks.size()) +
                                    " blocks, more than the limit of " +
                                    std::to_string(kMaxBlocks) + " (RTPLC_MAX_BLOCKS)");
    }
    return std::move(out_);
  }

 private:
  // ---- macro tables ----
  void index_macros() {
    for (const MacroDecl& d : prog_.decls) {
      if (!decls_.emplace(d.name, &d).second) {
        diags_.error(d.pos, "MACRO " + d.name + " is declared twice (first at line " +
                                std::to_string(decls_[d.name]->pos.line) + ")",
                     d.name_length);
      }
      if (d.name.size() > 31) {
        diags_.error(d.pos, "macro name longer than 31 characters", d.name_length);
      }
    }
    for (const MacroDef& def : prog_.defs) {
      if (!defs_.emplace(def.name, &def).second) {
        diags_.error(def.pos, "MACRO " + def.name + " is defined twice (first at line " +
                                  std::to_string(defs_[def.name]->pos.line) + ")",
                     def.name_length);
        continue;
      }
      if (check_definition(def)) valid_def_.insert(def.name);
    }
  }

  // Checks a definition's header against its declaration, once.
  bool check_definition(const MacroDef& def) {
    auto it = decls_.find(def.name);
    if (it == decls_.end()) {
      diags_.error(def.pos, "MACRO " + def.name + " is defined but not declared: add 'MACRO " +
                                def.name + "(l:m:n)' before the first %%",
                   def.name_length);
      return false;
    }
    const MacroDecl& decl = *it->second;
    bool ok = true;
    uint32_t n_m = 0, n_n = 0, n_p = 0;
    int phase = 0;  // 0 = M, 1 = N, 2 = P: formals come in that order
    std::unordered_set<std::string> seen;
    for (const Ref& f : def.formals) {
      int ph = f.letter == 'M' ? 0 : f.letter == 'N' ? 1 : f.letter == 'P' ? 2 : -1;
      if (ph < 0) {
        diags_.error(f.pos, "formal " + f.text() +
                                " must be M<n> (analog input), N<n> (digital input) or P<n> "
                                "(parameter)",
                     f.length);
        ok = false;
        continue;
      }
      if (ph < phase) {
        diags_.error(f.pos, "formal " + f.text() +
                                " is out of order: analog inputs (M) first, then digital (N), "
                                "then parameters (P)",
                     f.length);
        ok = false;
      }
      phase = std::max(phase, ph);
      if (!seen.insert(f.text()).second) {
        diags_.error(f.pos, "formal " + f.text() + " is listed twice", f.length);
        ok = false;
      }
      (ph == 0 ? n_m : ph == 1 ? n_n : n_p)++;
    }
    if (n_m != decl.n_analog || n_n != decl.n_digital || n_p != decl.n_params) {
      diags_.error(def.pos,
                   "MACRO " + def.name + " is declared at line " + std::to_string(decl.pos.line) +
                       " as (" + std::to_string(decl.n_analog) + ":" +
                       std::to_string(decl.n_digital) + ":" + std::to_string(decl.n_params) +
                       ") but defined with " + std::to_string(n_m) + " analog, " +
                       std::to_string(n_n) + " digital inputs and " + std::to_string(n_p) +
                       " parameters",
                   def.name_length);
      ok = false;
    }
    if (!def.has_return) {
      diags_.error(def.close_pos, "MACRO " + def.name +
                                      " has no RETURN(...): its last line must name the block "
                                      "whose output it returns, as in RETURN(M7)");
      ok = false;
    } else if (def.ret.letter != 'M' && def.ret.letter != 'N') {
      diags_.error(def.ret.pos, "RETURN must name an M (analog) or N (digital) block of the macro",
                   def.ret.length);
      ok = false;
    }
    return ok;
  }

  // ---- expansion ----
  void expand_body(const std::vector<Call>& calls, int scope) {
    for (const Call& c : calls) {
      if (c.is_macro) {
        expand_macro_call(c, scope);
      } else {
        add_primitive(c, scope);
      }
    }
  }

  // Introduces `target` in `scope`, reporting a duplicate.
  bool define(int scope, const Ref& target, Binding b) {
    Scope& s = scopes_[static_cast<size_t>(scope)];
    const uint64_t key = id_key(letter_kind(target.letter), target.number);
    auto [it, fresh] = s.ids.emplace(key, b);
    if (!fresh) {
      const Binding& first = it->second;
      std::string what = first.is_formal ? " is an input of the macro" : " is already defined";
      diags_.error(target.pos,
                   target.text() + what +
                       (first.pos.line ? " (line " + std::to_string(first.pos.line) + ")" : "") +
                       ": every block needs its own id",
                   target.length);
      return false;
    }
    return true;
  }

  void note_expansion(int scope) {
    const Scope& s = scopes_[static_cast<size_t>(scope)];
    if (!s.top && s.call_pos.line != 0) {
      diags_.note(s.call_pos, "in the expansion of MACRO " + s.macro + " called here");
    }
  }

  bool target_ok(const Call& c, const Scope& s, Kind out_kind) {
    const char l = c.target.letter;
    if (s.top && (l == 'M' || l == 'N')) {
      diags_.error(c.target.pos, c.target.text() +
                                     ": M and N ids belong inside macro definitions; in the "
                                     "program body use F (analog) or D (digital)",
                   c.target.length);
      return false;
    }
    if (!s.top && (l == 'F' || l == 'D')) {
      diags_.error(c.target.pos, c.target.text() +
                                     ": inside a macro, blocks are named M (analog) or N "
                                     "(digital)",
                   c.target.length);
      return false;
    }
    if (l == 'P') {
      diags_.error(c.target.pos, c.target.text() +
                                     " is a parameter name and cannot hold a block's output",
                   c.target.length);
      return false;
    }
    if (letter_kind(l) != out_kind) {
      const char want = s.top ? top_letter(out_kind) : macro_letter(out_kind);
      diags_.error(c.target.pos, c.name + " gives " +
                                     (out_kind == Kind::kAnalog ? "an analog" : "a digital") +
                                     " output: name it " + want +
                                     std::to_string(c.target.number) + ", not " +
                                     c.target.text(),
                   c.target.length);
      return false;
    }
    return true;
  }

  void add_primitive(const Call& c, int scope) {
    staged_.clear();
    const BlockSpec* spec = find_block(c.name);
    Scope& s = scopes_[static_cast<size_t>(scope)];
    if (spec == nullptr) {
      std::string msg = "unknown block '" + c.name + "'";
      if (decls_.count(c.name) || defs_.count(c.name)) {
        msg += ": " + c.name + " is a macro, call it as " +
               (c.has_target ? c.target.text() : std::string("F1")) + " = MACRO " + c.name +
               "(...)";
      } else if (std::string hint = suggest_block(c.name); !hint.empty()) {
        msg += "; did you mean '" + hint + "'?";
      } else {
        msg += " (rtplc blocks lists all 58)";
      }
      diags_.error(c.name_pos, msg, c.name_length);
      if (c.has_target) poison(scope, c.target);
      return;
    }
    if (!s.top && spec->io != IoGroup::kNone) {
      diags_.error(c.name_pos, std::string(spec->name) +
                                   ": I/O blocks are not allowed inside a macro (every call "
                                   "would use the same device address); put them in the "
                                   "program body and pass the value in",
                   c.name_length);
      if (c.has_target) poison(scope, c.target);
      return;
    }
    if (spec->has_output && !c.has_target) {
      diags_.error(c.name_pos, std::string(spec->name) + " needs an id for its result, as in " +
                                   (s.top ? top_letter(spec->out_kind) : macro_letter(spec->out_kind)) +
                                   "1 = " + spec->name + "(...)",
                   c.name_length);
      return;
    }
    if (!spec->has_output && c.has_target) {
      diags_.error(c.target.pos, std::string(spec->name) +
                                     " is an output block and has no result: write it without '" +
                                     c.target.text() + " ='",
                   c.target.length);
      return;
    }
    if (c.has_target && !target_ok(c, s, spec->out_kind)) {
      poison(scope, c.target);
      return;
    }

    FlatBlock b;
    b.spec = spec;
    b.written = c.name;
    b.pos = c.pos;
    b.call_line = s.call_line;
    bool ok = false;
    switch (spec->signature) {
      case Signature::kCompute: ok = compute_args(c, scope, b); break;
      case Signature::kDeviceIn: ok = device_in_args(c, b); break;
      case Signature::kSetpoint: ok = setpoint_args(c, b); break;
      case Signature::kDeviceOut: ok = device_out_args(c, scope, b); break;
    }
    if (!ok) {
      staged_.clear();
      if (c.has_target) poison(scope, c.target);
      note_expansion(scope);
      return;
    }
    b.op = block_op(*spec, b.n_in);
    if (c.has_target) {
      b.name = s.prefix + c.target.text();
    } else {
      b.name = std::string(spec->name) + "@" + device_text(b);
    }
    const auto index = static_cast<uint32_t>(out_.blocks.size());
    if (c.has_target) {
      Binding bind;
      bind.what = Binding::What::kBlock;
      bind.flat = index;
      bind.pos = c.target.pos;
      define(scope, c.target, bind);
      if (s.top) top_blocks_.push_back(index);
    }
    for (PendingInput& p : staged_) {
      p.block = index;
      pending_.push_back(p);
    }
    staged_.clear();
    out_.blocks.push_back(std::move(b));
  }

  void poison(int scope, const Ref& target) {
    Binding b;
    b.what = Binding::What::kPoison;
    b.pos = target.pos;
    define(scope, target, b);
    staged_.clear();
  }

  static std::string device_text(const FlatBlock& b) {
    if (b.spec->signature == Signature::kSetpoint) {
      return "d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
    }
    return "p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
  }

  // Accepts an input reference into slot `slot` of the block being built.
  bool input_arg(const Arg& a, int scope, Kind want, const char* input_name, const char* block,
                 uint32_t slot, FlatBlock& b) {
    if (a.kind != Arg::Kind::kRef || !is_value_letter(a.ref.letter)) {
      std::string found = a.kind == Arg::Kind::kNumber   ? "a number"
                          : a.kind == Arg::Kind::kString ? "a string"
                          : a.kind == Arg::Kind::kDevice ? "a device address"
                                                         : "parameter " + a.ref.text();
      diags_.error(a.pos, std::string("input '") + input_name + "' of " + block +
                              " must be the id of a block" +
                              (a.kind == Arg::Kind::kNumber
                                   ? " (a constant input comes from a set-point block, asp)"
                                   : "") +
                              ", found " + found,
                   a.length);
      return false;
    }
    const Scope& s = scopes_[static_cast<size_t>(scope)];
    const char l = a.ref.letter;
    if (s.top && (l == 'M' || l == 'N')) {
      diags_.error(a.pos, a.ref.text() + " is a macro-internal name; the program body uses F and D",
                   a.length);
      return false;
    }
    if (!s.top && (l == 'F' || l == 'D')) {
      diags_.error(a.pos, a.ref.text() +
                              ": a macro cannot see the program's blocks; pass the value in "
                              "as an input (M/N)",
                   a.length);
      return false;
    }
    if (letter_kind(l) != want) {
      diags_.error(a.pos, std::string(want == Kind::kAnalog ? "analog" : "digital") + " input '" +
                              input_name + "' of " + block + " needs " +
                              (s.top ? top_letter(want) : macro_letter(want)) +
                              "<n>, but " + a.ref.text() + " is " +
                              (want == Kind::kAnalog ? "digital" : "analog"),
                   a.length);
      return false;
    }
    staged_.push_back(PendingInput{0, slot, scope, a.ref});
    b.in_pos[slot] = a.pos;
    return true;
  }

  // A literal parameter, or P<n> inside a macro. Returns false on error.
  bool param_arg(const Arg& a, int scope, const ParamSpec& ps, const char* block, double& out,
                 bool& known) {
    known = true;
    if (a.kind == Arg::Kind::kRef && a.ref.letter == 'P') {
      const Scope& s = scopes_[static_cast<size_t>(scope)];
      if (s.top) {
        diags_.error(a.pos, a.ref.text() + ": P<n> names a macro parameter and exists only inside "
                                           "a macro definition",
                     a.length);
        return false;
      }
      auto it = s.params.find(a.ref.number);
      if (it == s.params.end()) {
        diags_.error(a.pos, a.ref.text() + " is not a parameter of MACRO " + s.macro, a.length);
        return false;
      }
      known = it->second.known;
      out = it->second.value;
    } else if (a.kind == Arg::Kind::kNumber) {
      out = a.number;
    } else {
      diags_.error(a.pos, std::string("parameter '") + ps.name + "' (" + ps.meaning + ") of " +
                              block + " must be a number" +
                              (a.kind == Arg::Kind::kRef ? ", not a block id: parameters are "
                                                           "constants"
                                                         : ""),
                   a.length);
      return false;
    }
    if (!known) return true;
    std::string bound;
    if (ps.integer && out != std::floor(out)) bound = "a whole number";
    if (ps.min_exclusive ? !(out > ps.min) : !(out >= ps.min)) {
      bound = ps.min_exclusive ? "greater than " + format_number(ps.min) : "at least " + format_number(ps.min);
    }
    if (!(out <= ps.max)) bound = "at most " + format_number(ps.max);
    if (!bound.empty()) {
      diags_.error(a.pos, std::string("parameter '") + ps.name + "' (" + ps.meaning + ") of " +
                              block + " must be " + bound + ", found " + format_number(out),
                   a.length);
      return false;
    }
    return true;
  }

  bool compute_args(const Call& c, int scope, FlatBlock& b) {
    const BlockSpec& sp = *b.spec;
    // Inputs come first, then parameters; for and/or the input count varies.
    size_t n_refs = 0;
    while (n_refs < c.args.size() && c.args[n_refs].kind == Arg::Kind::kRef &&
           is_value_letter(c.args[n_refs].ref.letter)) {
      ++n_refs;
    }
    size_t n_in = std::clamp<size_t>(n_refs, sp.min_inputs, sp.max_inputs);
    if (sp.min_inputs != sp.max_inputs && n_refs < sp.min_inputs) n_in = sp.min_inputs;
    size_t required = 0;
    for (uint8_t k = 0; k < sp.param_count; ++k) {
      if (!sp.params[k].optional) required = k + 1u;
    }
    const size_t min_args = sp.min_inputs + required;
    const size_t max_args = sp.max_inputs + sp.param_count;
    if (c.args.size() < min_args || c.args.size() > max_args) {
      diags_.error(c.name_pos, arity_message(sp, c.args.size()), c.name_length);
      return false;
    }
    bool ok = true;
    b.n_in = static_cast<uint32_t>(n_in);
    for (size_t k = 0; k < n_in; ++k) {
      if (k >= c.args.size()) break;
      ok &= input_arg(c.args[k], scope, sp.input_kind[k], sp.input_names[k], sp.name,
                      static_cast<uint32_t>(k), b);
    }
    const size_t n_params_given = c.args.size() - n_in;
    if (n_params_given < required) {
      diags_.error(c.name_pos, arity_message(sp, c.args.size()), c.name_length);
      return false;
    }
    bool all_known = true;
    for (uint8_t k = 0; k < sp.param_count; ++k) {
      double v = sp.params[k].default_value;
      if (k < n_params_given) {
        bool known = true;
        ok &= param_arg(c.args[n_in + k], scope, sp.params[k], sp.name, v, known);
        all_known &= known;
      }
      b.params.push_back(v);
    }
    if (ok && all_known && std::string_view(sp.name) == "lim" && b.params[0] > b.params[1]) {
      diags_.error(c.args[n_in].pos, "lim: lower limit " + format_number(b.params[0]) +
                                         " is above the upper limit " + format_number(b.params[1]),
                   c.args[n_in].length);
      ok = false;
    }
    return ok;
  }

  static std::string arity_message(const BlockSpec& sp, size_t found) {
    std::string form = std::string(sp.name) + "(";
    for (uint8_t k = 0; k < sp.max_inputs; ++k) {
      if (k) form += ", ";
      form += k >= sp.min_inputs ? std::string("[") + sp.input_names[k] + "]" : sp.input_names[k];
    }
    for (uint8_t k = 0; k < sp.param_count; ++k) {
      if (k || sp.max_inputs) form += ", ";
      form += sp.params[k].optional ? std::string("[") + sp.params[k].name + "]" : sp.params[k].name;
    }
    form += ")";
    return std::string(sp.name) + " takes " + form + ", found " + std::to_string(found) +
           " argument" + (found == 1 ? "" : "s");
  }

  bool device(const Arg& a, char letter, uint32_t max, uint32_t& out, const char* block) {
    if (a.kind != Arg::Kind::kDevice || a.device != letter) {
      const char* what = letter == 'p' ? "processor" : letter == 'd' ? "module" : "channel";
      diags_.error(a.pos, std::string(block) + " expects the " + what + " address here, like " +
                              letter + "0",
                   a.length);
      return false;
    }
    if (a.device_no > max) {
      diags_.error(a.pos, std::string(1, letter) + " number " + std::to_string(a.device_no) +
                              " is out of range (0.." + std::to_string(max) + ")",
                   a.length);
      return false;
    }
    out = a.device_no;
    return true;
  }

  bool label_arg(const Call& c, size_t idx, FlatBlock& b) {
    if (idx >= c.args.size()) {
      b.label = std::string(b.spec->name) + "_" + device_text(b);
      for (char& ch : b.label) {
        if (ch == '.') ch = '_';
      }
      return true;
    }
    const Arg& a = c.args[idx];
    if (a.kind != Arg::Kind::kString) {
      diags_.error(a.pos, std::string(b.spec->name) + " expects a \"label\" as its last argument",
                   a.length);
      return false;
    }
    if (a.text.empty() || a.text.size() > 31) {
      diags_.error(a.pos, "a label must have 1 to 31 characters", a.length);
      return false;
    }
    for (char ch : a.text) {
      if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.')) {
        diags_.error(a.pos, "label \"" + a.text +
                                "\" may only use letters, digits, '_', '-' and '.' (it names a "
                                "channel on the command line and in CSV headers)",
                     a.length);
        return false;
      }
    }
    b.label = a.text;
    return true;
  }

  bool device_in_args(const Call& c, FlatBlock& b) {
    const char* n = b.spec->name;
    if (c.args.size() < 3 || c.args.size() > 4) {
      diags_.error(c.name_pos, std::string(n) + " takes (p, d, c, \"label\"), found " +
                                   std::to_string(c.args.size()) + " arguments",
                   c.name_length);
      return false;
    }
    uint32_t p = 0, d = 0;
    bool ok = device(c.args[0], 'p', 255, p, n) & device(c.args[1], 'd', 255, d, n) &
              device(c.args[2], 'c', 65535, b.c, n);
    b.p = static_cast<uint16_t>(p);
    b.d = static_cast<uint16_t>(d);
    return ok && label_arg(c, 3, b);
  }

  bool setpoint_args(const Call& c, FlatBlock& b) {
    const char* n = b.spec->name;
    if (c.args.size() < 3 || c.args.size() > 4) {
      diags_.error(c.name_pos, std::string(n) + " takes (d, c, init, \"label\"), found " +
                                   std::to_string(c.args.size()) + " arguments",
                   c.name_length);
      return false;
    }
    uint32_t d = 0;
    bool ok = device(c.args[0], 'd', 255, d, n) & device(c.args[1], 'c', 65535, b.c, n);
    b.d = static_cast<uint16_t>(d);
    const Arg& init = c.args[2];
    if (init.kind != Arg::Kind::kNumber) {
      diags_.error(init.pos, std::string(n) + " expects its initial value here", init.length);
      ok = false;
    } else if (b.spec->out_kind == Kind::kDigital && init.number != 0 && init.number != 1) {
      diags_.error(init.pos, "a digital set-point starts at 0 or 1", init.length);
      ok = false;
    } else {
      b.init = init.number;
    }
    return ok && label_arg(c, 3, b);
  }

  bool device_out_args(const Call& c, int scope, FlatBlock& b) {
    const char* n = b.spec->name;
    if (c.args.size() < 4 || c.args.size() > 5) {
      diags_.error(c.name_pos, std::string(n) + " takes (value, p, d, c, \"label\"), found " +
                                   std::to_string(c.args.size()) + " arguments",
                   c.name_length);
      return false;
    }
    b.n_in = 1;
    uint32_t p = 0, d = 0;
    bool ok = input_arg(c.args[0], scope, b.spec->input_kind[0], "value", n, 0, b);
    ok &= device(c.args[1], 'p', 255, p, n) & device(c.args[2], 'd', 255, d, n) &
          device(c.args[3], 'c', 65535, b.c, n);
    b.p = static_cast<uint16_t>(p);
    b.d = static_cast<uint16_t>(d);
    return ok && label_arg(c, 4, b);
  }

  void expand_macro_call(const Call& c, int scope) {
    const Scope& caller = scopes_[static_cast<size_t>(scope)];
    called_.insert(c.name);
    auto di = decls_.find(c.name);
    auto fi = defs_.find(c.name);
    if (di == decls_.end()) {
      std::string msg = "MACRO " + c.name + " is not declared";
      if (find_block(c.name)) msg += "; '" + c.name + "' is a primitive block: drop 'MACRO'";
      else msg += ": declare it before the first %% as MACRO " + c.name + "(l:m:n)";
      diags_.error(c.name_pos, msg, c.name_length);
      poison(scope, c.target);
      return;
    }
    const MacroDecl& decl = *di->second;
    if (fi == defs_.end()) {
      diags_.error(c.name_pos, "MACRO " + c.name + " is declared (line " +
                                   std::to_string(decl.pos.line) +
                                   ") but has no definition after END",
                   c.name_length);
      poison(scope, c.target);
      return;
    }
    const MacroDef& def = *fi->second;
    const size_t want = decl.n_analog + decl.n_digital + decl.n_params;
    if (c.args.size() != want) {
      diags_.error(c.name_pos, "MACRO " + c.name + " takes " + std::to_string(want) +
                                   " arguments (" + std::to_string(decl.n_analog) + " analog, " +
                                   std::to_string(decl.n_digital) + " digital, " +
                                   std::to_string(decl.n_params) +
                                   " parameters, as declared at line " +
                                   std::to_string(decl.pos.line) + "), found " +
                                   std::to_string(c.args.size()),
                   c.name_length);
      poison(scope, c.target);
      return;
    }
    if (std::find(stack_.begin(), stack_.end(), c.name) != stack_.end()) {
      std::string chain;
      for (const std::string& m : stack_) chain += m + " -> ";
      diags_.error(c.name_pos, "recursive macro call: " + chain + c.name +
                                   " (a macro is expanded in place and cannot call itself)",
                   c.name_length);
      poison(scope, c.target);
      return;
    }
    if (stack_.size() >= kMaxMacroDepth) {
      diags_.error(c.name_pos, "macro calls nested deeper than " + std::to_string(kMaxMacroDepth),
                   c.name_length);
      poison(scope, c.target);
      return;
    }
    if (valid_def_.count(c.name) == 0) {  // its header errors were already reported
      poison(scope, c.target);
      return;
    }
    Kind ret_kind = letter_kind(def.ret.letter);
    if (!target_ok_for_macro(c, caller, ret_kind)) {
      poison(scope, c.target);
      return;
    }

    Scope child;
    child.parent = scope;
    child.top = false;
    child.prefix = caller.prefix + c.target.text() + ".";
    child.call_line = caller.top ? c.pos.line : caller.call_line;
    child.call_pos = caller.top ? c.name_pos : caller.call_pos;
    child.macro = c.name;
    bool ok = true;
    size_t k = 0;
    for (const Ref& f : def.formals) {
      const Arg& a = c.args[k++];
      if (f.letter == 'P') {
        ParamSpec ps{"", "", 0, false, -1e300, 1e300, false, false};
        ps.name = "parameter";
        ps.meaning = "macro parameter";
        double v = 0;
        bool known = true;
        if (!param_arg(a, scope, ps, ("MACRO " + c.name).c_str(), v, known)) {
          ok = false;
          continue;
        }
        child.params[f.number] = ParamBinding{known, v};
        continue;
      }
      Kind fkind = letter_kind(f.letter);
      if (a.kind != Arg::Kind::kRef || !is_value_letter(a.ref.letter) ||
          letter_kind(a.ref.letter) != fkind || (caller.top != (a.ref.letter == 'F' || a.ref.letter == 'D'))) {
        diags_.error(a.pos, "argument " + std::to_string(k) + " of MACRO " + c.name +
                                " is its input " + f.text() + " and must be " +
                                (fkind == Kind::kAnalog ? "an analog" : "a digital") +
                                " block id (" + (caller.top ? top_letter(fkind) : macro_letter(fkind)) +
                                "<n>)",
                     a.length);
        ok = false;
        continue;
      }
      Binding alias;
      alias.what = Binding::What::kAlias;
      alias.alias_scope = scope;
      alias.alias_ref = a.ref;
      alias.is_formal = true;
      alias.pos = f.pos;
      child.ids.emplace(id_key(fkind, f.number), alias);
    }
    if (!ok) {
      poison(scope, c.target);
      return;
    }
    ++out_.macro_calls;
    expanded_.insert(c.name);
    const int child_id = static_cast<int>(scopes_.size());
    scopes_.push_back(std::move(child));
    const size_t before = out_.blocks.size();
    stack_.push_back(c.name);
    expand_body(def.body, child_id);
    stack_.pop_back();
    const size_t produced = out_.blocks.size() - before;
    if (produced > kMaxMacroBlocks && !reported_size_.count(def.name)) {
      reported_size_.insert(def.name);
      diags_.error(def.pos, "MACRO " + def.name + " expands to " + std::to_string(produced) +
                                " primitive blocks, more than the limit of " +
                                std::to_string(kMaxMacroBlocks) + " (RTPLC_MAX_MACRO_BLOCKS)",
                   def.name_length);
    }
    Binding result;
    result.what = Binding::What::kAlias;
    result.alias_scope = child_id;
    result.alias_ref = def.ret;
    result.pos = c.target.pos;
    define(scope, c.target, result);
    macro_results_.push_back({c.target, scope});
  }

  bool target_ok_for_macro(const Call& c, const Scope& s, Kind ret_kind) {
    Call fake = c;
    fake.name = "MACRO " + c.name;
    return target_ok(fake, s, ret_kind);
  }

  // Checks an uncalled macro's body with its inputs unresolved and its
  // parameters unknown, so a typo in it is found before the day it is called.
  void dry_check(const MacroDef& def) {
    Scope child;
    child.parent = -1;
    child.top = false;
    child.prefix = "?" + def.name + ".";
    child.macro = def.name;
    for (const Ref& f : def.formals) {
      if (f.letter == 'P') {
        child.params[f.number] = ParamBinding{false, 0};
      } else {
        Binding b;
        b.what = Binding::What::kPoison;
        b.is_formal = true;
        b.pos = f.pos;
        child.ids.emplace(id_key(letter_kind(f.letter), f.number), b);
      }
    }
    const int id = static_cast<int>(scopes_.size());
    scopes_.push_back(std::move(child));
    const size_t blocks_before = out_.blocks.size();
    const size_t pending_before = pending_.size();
    const uint32_t calls_before = out_.macro_calls;
    stack_.push_back(def.name);
    expand_body(def.body, id);
    stack_.pop_back();
    // Resolve only to report undefined names; the blocks themselves are discarded.
    for (size_t i = pending_before; i < pending_.size(); ++i) resolve(pending_[i].scope, pending_[i].ref);
    Ref ret = def.ret;
    resolve(id, ret);
    pending_.resize(pending_before);
    out_.blocks.resize(blocks_before);
    out_.macro_calls = calls_before;
  }

  // ---- resolution ----
  // Follows aliases to the producing block. Returns false (after reporting) if
  // the name is undefined or poisoned.
  bool resolve(int scope, const Ref& ref, uint32_t* flat = nullptr) {
    int s = scope;
    Ref r = ref;
    for (int hops = 0; hops < 64; ++hops) {
      const Scope& sc = scopes_[static_cast<size_t>(s)];
      auto it = sc.ids.find(id_key(letter_kind(r.letter), r.number));
      if (it == sc.ids.end()) {
        std::string msg = r.text() + " is not defined";
        auto other = sc.ids.find(id_key(letter_kind(r.letter) == Kind::kAnalog ? Kind::kDigital
                                                                                : Kind::kAnalog,
                                        r.number));
        if (other != sc.ids.end()) {
          const char ol = sc.top ? top_letter(letter_kind(r.letter) == Kind::kAnalog
                                                   ? Kind::kDigital
                                                   : Kind::kAnalog)
                                 : macro_letter(letter_kind(r.letter) == Kind::kAnalog
                                                    ? Kind::kDigital
                                                    : Kind::kAnalog);
          msg += " (" + std::string(1, ol) + std::to_string(r.number) + " is, but it is " +
                 (letter_kind(r.letter) == Kind::kAnalog ? "digital" : "analog") + ")";
        } else if (!sc.top) {
          msg += " in MACRO " + sc.macro;
        }
        diags_.error(r.pos, msg, r.length);
        return false;
      }
      const Binding& b = it->second;
      switch (b.what) {
        case Binding::What::kPoison:
          return false;
        case Binding::What::kBlock:
          if (flat) *flat = b.flat;
          return true;
        case Binding::What::kAlias:
          s = b.alias_scope;
          r = b.alias_ref;
          break;
      }
    }
    diags_.error(ref.pos, ref.text() + " is defined only in terms of itself (through a macro "
                                       "that returns its own input)",
                 ref.length);
    return false;
  }

  void resolve_all() {
    for (const PendingInput& p : pending_) {
      uint32_t flat = 0;
      if (!resolve(p.scope, p.ref, &flat)) continue;
      FlatBlock& b = out_.blocks[p.block];
      b.in[p.slot] = flat;
      b.delayed[p.slot] = flat >= p.block;
      used_.insert(flat);
    }
    // A call whose RETURN names an undefined block is reported here.
    for (const auto& [target, scope] : macro_results_) resolve(scope, target);
  }

  // One writer per output channel; one definition per set-point; a label names
  // one channel (it is how `rtplc set` and the CSV header find it).
  void check_channels() {
    std::map<std::string, const FlatBlock*> writers, setpoints, inputs;
    std::map<std::string, std::pair<std::string, const FlatBlock*>> labels;
    for (const FlatBlock& b : out_.blocks) {
      if (b.spec->io == IoGroup::kNone) continue;
      std::string chan = channel_key(b);
      auto prior = [&](const FlatBlock* f) { return " (line " + std::to_string(f->pos.line) + ")"; };
      if (b.spec->signature == Signature::kDeviceOut) {
        auto [it, fresh] = writers.emplace(chan, &b);
        if (!fresh) {
          diags_.error(b.pos, "channel " + chan + " is already written by " + it->second->written +
                                  prior(it->second) + ": each output channel has one writer");
          continue;
        }
      } else if (b.spec->signature == Signature::kSetpoint) {
        auto [it, fresh] = setpoints.emplace(chan, &b);
        if (!fresh) {
          diags_.error(b.pos, "set-point " + chan + " is already defined" + prior(it->second));
          continue;
        }
      } else {
        auto [it, fresh] = inputs.emplace(chan, &b);
        if (!fresh && it->second->label != b.label) {
          diags_.warning(b.pos, "channel " + chan + " is read again under another label ('" +
                                    b.label + "' here, '" + it->second->label + "'" +
                                    prior(it->second) + ")");
        }
        if (!fresh) continue;
      }
      auto [lit, fresh_label] = labels.emplace(b.label, std::make_pair(chan, &b));
      if (!fresh_label && lit->second.first != chan) {
        diags_.error(b.pos, "label \"" + b.label + "\" already names channel " + lit->second.first +
                                prior(lit->second.second) + "; give each channel its own label");
      } else if (!fresh_label && b.spec->signature == Signature::kDeviceOut) {
        diags_.error(b.pos, "label \"" + b.label + "\" is used for both reading and writing " +
                                chan);
      }
    }
  }

  static std::string channel_key(const FlatBlock& b) {
    std::string g = io_group_name(b.spec->io);
    if (b.spec->device_kind != 0) g += std::string(1, b.spec->device_kind);
    if (b.spec->signature == Signature::kSetpoint) {
      return g + " d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
    }
    return g + " p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" +
           std::to_string(b.c);
  }

  void check_unused() {
    if (diags_.has_errors()) return;
    for (uint32_t idx : top_blocks_) {
      const FlatBlock& b = out_.blocks[idx];
      if (b.spec->signature != Signature::kCompute) continue;
      if (used_.count(idx) == 0) {
        diags_.warning(b.pos, b.name + " (" + b.written + ") is computed but never used");
      }
    }
  }

  const Program& prog_;
  DiagnosticList& diags_;
  CheckedProgram out_;
  std::vector<Scope> scopes_;
  std::vector<PendingInput> pending_;
  std::vector<PendingInput> staged_;
  std::vector<std::string> stack_;
  std::vector<uint32_t> top_blocks_;
  std::vector<std::pair<Ref, int>> macro_results_;
  std::unordered_set<uint32_t> used_;
  std::map<std::string, const MacroDecl*> decls_;
  std::map<std::string, const MacroDef*> defs_;
  std::unordered_set<std::string> valid_def_;
  std::unordered_set<std::string> expanded_;
  std::unordered_set<std::string> called_;
  std::unordered_set<std::string> reported_size_;
};

}  // namespace

CheckedProgram check_program(const Program& prog, DiagnosticList& diags) {
  return Checker(prog, diags).run();
}

}  // namespace rtplc::lang
