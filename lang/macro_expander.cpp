// FBD macro expansion (spec fbd-language.md: "Macros", "Blocks and ids",
// "Errors"): Program (as written) -> CheckedProgram, a flat list of primitive
// blocks in textual order with every input resolved to the block that produces
// it. Everything FBD-specific about checking lives here and in
// lang/fbd_arguments.cpp: macro declarations and definitions, arity against the
// declaration, RETURN, recursion (reported with the call chain), nesting and size
// limits, per-call expansion, F/D/M/N/P letters and their scopes. What any
// language must satisfy is checked by lang/program_checks.h, called from
// check_program() below.
//
// Names are resolved after the whole program is expanded, because a reference may
// point at a block further down the file (a one-cycle delay). Each macro call
// gets its own scope whose formals are aliases of the caller's arguments, and the
// call's result id is an alias of the macro's RETURN id inside that scope; an
// input is resolved by following aliases until a real block is reached.
#include "lang/macro_expander.h"

#include <algorithm>
#include <map>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "common/capacities.h"
#include "common/text.h"
#include "lang/fbd_scope.h"
#include "lang/program_checks.h"

namespace rtplc::lang {
namespace {

using fbd::ArgumentContext;
using FbdBinding = fbd::Binding;
using fbd::id_key;
using fbd::is_value_letter;
using fbd::letter_kind;
using fbd::macro_letter;
using fbd::ParamBinding;
using fbd::PendingInput;
using fbd::Scope;
using fbd::top_letter;

class MacroExpander {
 public:
  MacroExpander(const Program& prog, DiagnosticList& d) : prog_(prog), diags_(d) {}

  // Expands the program body and resolves every input. The result still has to
  // pass the language-neutral whole-program checks.
  CheckedProgram expand() {
    index_macros();
    out_.period = prog_.has_stime ? prog_.stime : kDefaultPeriod;
    out_.period_from_stime = prog_.has_stime;
    out_.stime_pos = prog_.stime_pos;

    scopes_.push_back(Scope{});  // top level
    expand_body(prog_.body, 0);
    resolve_all();
    return std::move(out_);
  }

  // What is left once the program itself is checked: macros nobody calls (still
  // checked, with unknown parameter values), declarations without a use, and
  // the default period. `p` is the expanded program; dry checks borrow it.
  void check_leftovers(CheckedProgram& p) {
    out_ = std::move(p);
    for (const MacroDef& def : prog_.defs) {
      if (expanded_.count(def.name) == 0 && valid_def_.count(def.name) != 0) dry_check(def);
    }
    for (const MacroDecl& d : prog_.decls) {
      if (defs_.count(d.name) == 0 && called_.count(d.name) == 0) {
        diags_.warning(d.pos, "MACRO " + d.name + " is declared but never defined or used",
                       d.name_length);
      }
    }
    if (!prog_.has_stime && !prog_.stime_written && !prog_.body.empty()) {
      diags_.note(SourcePos{}, "no stime(...) in the program: the task period defaults to " +
                                   format_number(kDefaultPeriod) + " s");
    }
    p = std::move(out_);
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
  bool define(int scope, const Ref& target, FbdBinding b) {
    Scope& s = scopes_[static_cast<size_t>(scope)];
    const uint64_t key = id_key(letter_kind(target.letter), target.number);
    auto [it, fresh] = s.ids.emplace(key, b);
    if (!fresh) {
      const FbdBinding& first = it->second;
      const char* what = first.is_formal ? " is an input of the macro" : " is already defined";
      diags_.error(target.pos, duplicate_name_message(target.text(), what, first.pos.line),
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
      } else {
        msg += unknown_block_hint(c.name);
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
    if (!fbd::bind_call_arguments(c, ArgumentContext{s, scope, staged_, diags_}, b)) {
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
      FbdBinding bind;
      bind.what = FbdBinding::What::kBlock;
      bind.flat = index;
      bind.pos = c.target.pos;
      define(scope, c.target, bind);
    }
    for (PendingInput& p : staged_) {
      p.block = index;
      pending_.push_back(p);
    }
    staged_.clear();
    out_.blocks.push_back(std::move(b));
  }

  void poison(int scope, const Ref& target) {
    FbdBinding b;
    b.what = FbdBinding::What::kPoison;
    b.pos = target.pos;
    define(scope, target, b);
    staged_.clear();
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
        if (!fbd::bind_parameter(a, ArgumentContext{caller, scope, staged_, diags_}, ps,
                                 ("MACRO " + c.name).c_str(), v, known)) {
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
      FbdBinding alias;
      alias.what = FbdBinding::What::kAlias;
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
    FbdBinding result;
    result.what = FbdBinding::What::kAlias;
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
        FbdBinding b;
        b.what = FbdBinding::What::kPoison;
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
      const FbdBinding& b = it->second;
      switch (b.what) {
        case FbdBinding::What::kPoison:
          return false;
        case FbdBinding::What::kBlock:
          if (flat) *flat = b.flat;
          return true;
        case FbdBinding::What::kAlias:
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
    }
    // A call whose RETURN names an undefined block is reported here.
    for (const auto& [target, scope] : macro_results_) resolve(scope, target);
  }

  const Program& prog_;
  DiagnosticList& diags_;
  CheckedProgram out_;
  std::vector<Scope> scopes_;
  std::vector<PendingInput> pending_;
  std::vector<PendingInput> staged_;
  std::vector<std::string> stack_;
  std::vector<std::pair<Ref, int>> macro_results_;
  std::map<std::string, const MacroDecl*> decls_;
  std::map<std::string, const MacroDef*> defs_;
  std::unordered_set<std::string> valid_def_;
  std::unordered_set<std::string> expanded_;
  std::unordered_set<std::string> called_;
  std::unordered_set<std::string> reported_size_;
};

}  // namespace

CheckedProgram check_program(const Program& prog, DiagnosticList& diags) {
  // The order of the phases is the order diagnostics have always come in.
  MacroExpander fbd(prog, diags);
  CheckedProgram p = fbd.expand();
  mark_delayed_inputs(p);
  check_io_channels(p, diags);
  check_quality_inputs(p, diags);
  warn_unused_results(p, diags);
  fbd.check_leftovers(p);
  check_program_size(p, diags);
  return p;
}

}  // namespace rtplc::lang
