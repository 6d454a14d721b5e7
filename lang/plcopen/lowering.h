// POU instances -> blocks (docs/plcopen.md, "How a POU becomes blocks"). The
// shared state of lowering one task: scopes of variables with their current
// value during the cycle, function block instances, and the body lowerings
// (graph.cpp for FBD and LD, st_lowering.cpp for ST, il.cpp, sfc.cpp).
//
// Variables. Every variable of a program or FB instance ends the cycle in a
// copy block named by its instance path ("main.level", "main.fb1.count"); a
// read before any assignment in the cycle reads that block, which runs later,
// so it is last cycle's value (the one-cycle rule). Initial values enter
// through `plcopen.first`. Stateful blocks are named by instance path too, so
// hot swap (matching by name) keeps timers, counters and latches.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "lang/compiler.h"
#include "lang/iec/iec_functions.h"
#include "lang/plcopen/emitter.h"
#include "lang/plcopen/project.h"
#include "lang/plcopen/st.h"

namespace rtplc::lang::sfc {
struct Chart;
struct HostLink;
}  // namespace rtplc::lang::sfc

namespace rtplc::lang::plcopen {

struct Scope;

// A located variable's place in the image (docs/plcopen.md, "Located variables").
struct Location {
  char area = 0;  // 'I', 'Q', 'M'
  char size = 0;  // 'X', 'W', 'D', 'L'
  uint32_t p = 0, d = 0, c = 0;
};

struct StdFb {
  std::string type;  // upper-case IEC name
  const iec::IecFunction* iec = nullptr;  // its row in lang/iec's table
  bool called = false;
};

struct Var {
  const Variable* decl = nullptr;
  std::string path;
  bool digital = false;
  bool integer = false;
  enum class Role : uint8_t { kPlain, kInput, kSetpoint, kUserFb, kStdFb, kStruct, kArray, kInOut } role = Role::kPlain;
  std::optional<Location> loc;
  bool hmi = false;  // an HMI variable: its channel is labelled with its path
  // A STRING (docs/st.md, "Strings") and the most characters it holds.
  bool str = false;
  bool wide = false;  // a WSTRING
  uint32_t cap = 0;
  std::optional<Value> start;  // the value at the start of the cycle
  std::optional<Value> cur;    // after the last assignment so far
  std::unique_ptr<Scope> fb;   // kUserFb: the instance's own variables; kStruct: its members
  StdFb std_fb;                // kStdFb
  // kArray: one variable per element, row-major (`a[1,2]` after `a[1,1]`).
  std::vector<std::unique_ptr<Var>> elems;
  std::shared_ptr<const ArrayType> array;
  // kInOut (VAR_IN_OUT): no storage of its own; the caller's variable, bound
  // by the call, which every read and write of the name reaches.
  Var* alias = nullptr;
};

// Where a path such as `a[i].x` leads: one variable, or (an index known only
// at run time) each element it may name with the condition that it does.
// `output` names a standard FB's output (`t[2].Q`).
struct Place {
  Value when;  // constant TRUE for a place known at compile time
  Var* var = nullptr;
  std::string output;
  bool in_instance = false;  // a variable of an FB instance (`fb1.q`), not the body's own
};

struct Scope {
  std::string path;
  const Pou* pou = nullptr;
  std::map<std::string, std::unique_ptr<Var>> vars;  // by upper-case name
  Scope* globals = nullptr;
  bool function = false;  // a function call: no memory between cycles
  bool called = false;
};

class Lowering {
 public:
  Lowering(const Project& p, CheckedProgram& out, DiagnosticList& d);

  // Lowers program instance `path` of `pou`, then (after all) finish().
  void program_instance(const Pou& pou, const std::string& path,
                        const std::vector<PouInstance::Connection>& connections = {});
  void set_globals(const std::vector<const Variable*>& globals);
  bool finish();

  // ---- shared by the body lowerings ----
  Var* lookup(Scope& s, const std::string& name, SourcePos pos, bool report = true);
  // "a" or "fb1.Q": the variable read or written.
  Var* resolve_path(Scope& s, const std::string& path, SourcePos pos);
  // A path with array indices (Expr::name with `[#n]`, their expressions in
  // `index`): every place it may lead to; empty after an error.
  std::vector<Place> places(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                            SourcePos pos);
  // The structure or array a plain path (`p`, `fb1.p`, `s.inner`, no index)
  // names; nullptr, without a message, for anything else.
  Var* whole_var(Scope& s, const std::string& path);
  // dst := src for a whole structure or array of one type, member by member
  // (element by element); false after an error.
  bool assign_whole(Var& dst, Var& src, SourcePos pos);
  // The structure or array variable of user FB instance `fb` (or user
  // function `function`) that formal parameter `formal` names; nullptr when
  // it is a plain one.
  Var* whole_member(const Var* fb, const std::string& formal) const;
  bool whole_parameter(const std::string& function, const std::string& formal) const;
  // One place known at compile time (an FBD/LD/IL target, an FB to call).
  Var* resolve_static(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                      SourcePos pos);
  // Reads or writes through a path: an index known only at run time reads
  // sel(i = 0, a[0], sel(i = 1, a[1], ...)) (0 when out of range) and writes
  // each element under its condition (none when out of range).
  Value load(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index, SourcePos pos);
  void store(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index, const Value& v,
             SourcePos pos);
  Value read(Var& v, SourcePos pos);
  // read() of a variable of an FB instance from outside it: its name is not
  // one the reading body writes, so the body's data-flow order is not asked.
  Value read_from_outside(Var& v, SourcePos pos);
  void assign(Var& v, Value value, SourcePos pos);
  // `value` rounded to the grid of `per` steps a second (a TIME's 1e9:
  // round(x * per) / per), so sums of times do not drift.
  Value on_time_grid(const Value& value, double per, SourcePos pos);
  // Rising edge of `v`, remembered in a block named `mem` (last cycle's `v`).
  Value rising(const Value& v, const std::string& mem, SourcePos pos);
  Value falling(const Value& v, const std::string& mem, SourcePos pos);

  // A call of a standard or user function with positional arguments (after
  // formal names were put in order); nullopt when `name` is no function.
  // `wholes`: (formal, caller's structure or array) copied into the
  // function's parameter of that name.
  std::optional<Value> call_function(Scope& s, const std::string& name,
                                     std::vector<Value> args, std::vector<std::string> formals,
                                     SourcePos pos, const std::vector<std::pair<std::string, Var*>>& inouts = {},
                                     const std::vector<std::pair<std::string, Var*>>& wholes = {});
  bool is_function(const std::string& upper_name) const;
  // LEN, LEFT, ..., the *_TO_STRING and STRING_TO_* conversions (strings.cpp):
  // nullopt when `up` is none of them.
  std::optional<Value> call_string_function(const std::string& up, const std::vector<Value>& args,
                                            const std::vector<std::string>& formals, SourcePos pos);
  // The default length of a STRING: the project's editor's (126 MatIEC, 80 CODESYS).
  uint32_t default_string_length() const;
  // Lowers standard function or block `f` through lang/iec's table, arguments
  // by formal position (nullopt: unconnected, the IEC default), its blocks named
  // under `prefix`. The value of each formal output; empty after an error.
  std::vector<Value> lower_iec(const iec::IecFunction& f, const std::string& prefix,
                               const std::vector<std::optional<Value>>& args, SourcePos pos);
  // The ST and IL operators: `a + b` is ADD(a, b), `NOT x` is NOT(x), lowered
  // through lang/iec's table like a call (so INT arithmetic wraps and NOT on a
  // DINT has 32 bits); only constant operands fold here.
  Value operate(BinOp op, const Value& a, const Value& b, SourcePos pos);
  Value operate(const char* iec_name, const Value& a, SourcePos pos);
  // Calls FB instance `v` with named inputs; its outputs are then read with
  // fb_output(). A second call in one cycle is refused.
  void call_fb(Var& v, const std::vector<std::pair<std::string, Value>>& inputs, SourcePos pos,
               const std::vector<std::pair<std::string, Var*>>& inouts = {});
  // True when `formal` is a VAR_IN_OUT of the user FB instance or user
  // function `callee` names (the argument is then a variable, not a value).
  bool is_in_out(const Var* fb, const std::string& function, const std::string& formal) const;
  // The caller's variable an argument for VAR_IN_OUT `formal` names.
  Var* in_out_argument(Scope& s, const Expr& e, const std::string& formal, SourcePos pos);
  Value fb_output(Var& v, const std::string& name, SourcePos pos);
  // A standard FB instance called in several branches of one IF or CASE
  // (`IF c THEN t(IN := TRUE); ELSE t(IN := FALSE); END_IF;`): between
  // begin_gathered and end_gathered its calls are only noted, and at the
  // END_IF it runs once on the inputs of the branch taken (the branches are
  // exclusive, so at most one call happens in a cycle).
  void begin_gathered(Var& v);
  void end_gathered(Var& v, SourcePos pos);
  bool gathered(const Var& v) const { return gathered_.count(&v) != 0; }
  // A branch of a two-pass IF starts here: reading `v`'s outputs is refused
  // only after a call noted in this branch (st_lowering.cpp, Split).
  void gathered_branch_starts(const Var& v) {
    auto g = gathered_.find(&v);
    gathered_floor_[&v] = g == gathered_.end() ? 0 : g->second.size();
  }
  size_t gathering() const { return gathered_.size(); }  // instances being gathered now
  bool fb_output_digital(const Var& v, const std::string& name) const;

  void lower_body(Scope& s);
  void lower_body_of(Scope& s, const Body& b);  // an SFC action's body too
  // Runs `f` as the then-branch of an if-converted IF on `cond`.
  void guarded(const Value& cond, SourcePos pos, const std::function<void()>& f);
  // The if-conversion's path: the branch conditions around the code being
  // lowered (pushed by the ST/IL branch, an FB's EN, an SFC action, an event
  // task). active() is 1 exactly in the cycles that code runs: a standard FB
  // called there advances only then (call_fb).
  void push_path(const Value& cond, bool negated);
  void pop_path();
  Value active(SourcePos pos);
  bool conditional() const { return !path_.empty(); }
  // Programs lowered after this run only in cycles where `trigger` rises
  // (a task with single="..."); SourcePos for its messages.
  void set_trigger(const std::string& variable, SourcePos pos);
  void set_semantics(EditorSemantics s) { semantics_ = s; }
  void lower_graph(Scope& s, const XmlElement& body, bool ladder);
  void lower_st(Scope& s, const Block& b);
  void lower_il(Scope& s, const Body& body);
  // The current result at the end of the last IL body lowered (an IL
  // transition's condition); nullopt after an error.
  const std::optional<Value>& il_result() const { return il_result_; }
  void lower_sfc(Scope& s, const XmlElement& body);
  // `b` runs only while `cond` holds (an SFC action): if-converted.
  void lower_st_guarded(Scope& s, const Block& b, const Value& cond, SourcePos pos);
  Value eval(Scope& s, const Expr& e);

  // Real loops (st_lowering.cpp, "loop"): while one is lowered, an array
  // indexed by a value known only at run time is read with one pick block and,
  // when all its elements have homes in the innermost loop, written with one
  // put block, instead of a choice among every element.
  struct LoopHome {
    Value value;     // the home's value as the body reads it
    size_t block = 0;  // its var block
  };
  // A home: a var block (its value read as `value`) that keeps a variable's
  // value across a backward jump, set by set_home (a set block).
  // `str_cap`: a STRING's home (an svar) of that length.
  LoopHome make_home(const std::string& stem, bool digital, bool integer, SourcePos pos,
                     std::optional<uint32_t> str_cap = std::nullopt, bool wide = false);
  // A home shaped as `v` holds it (a number, a BOOL, a STRING or WSTRING of its length).
  LoopHome make_home_for(const Value& v, const std::string& stem, SourcePos pos);
  // The home of variable `v` (its path, kind and string length).
  LoopHome make_home_for(const Var& v, SourcePos pos);
  void set_home(const LoopHome& h, const Value& v, SourcePos pos);
  // Sets `v`'s home `h` to `v`'s value now, unless that is the home's own
  // value already; true when it set it.
  bool sync_home(Var& v, const LoopHome& h, SourcePos pos);
  // Sets every home to its value at once, as a parallel assignment: a value
  // that is the home of another being set here (tmp := a; a := b; b := tmp in
  // a loop) is copied before any home is set. A value that is its home's own
  // already is left out.
  void set_homes(const std::vector<std::pair<const LoopHome*, Value>>& sets, SourcePos pos);
  // set_homes of each variable's home to the variable's value now.
  void sync_homes(const std::vector<std::pair<Var*, const LoopHome*>>& homes, SourcePos pos);
  void enter_loop(std::map<const Var*, LoopHome> homes) { loops_.push_back(std::move(homes)); }
  void leave_loop() { loops_.pop_back(); }

  // Values of every variable's `cur` (if-conversion).
  std::vector<std::optional<Value>> save() const;
  void restore(const std::vector<std::optional<Value>>& st);
  void note(const std::string& n) { out_.notes.push_back(n); }
  std::vector<Var*> vars_for_merge() const { return all_vars_; }

  Emitter& em() { return em_; }
  // The POUs whose bodies were lowered (program instances, FB instances called,
  // function calls); an FB instance declared and never called is not one.
  const std::set<const Pou*>& lowered_pous() const { return lowered_pous_; }
  DiagnosticList& diags() { return d_; }
  const Project& project() const { return proj_; }
  // Set by the graph lowering: before a read of variable X, lower the elements
  // of this body that write X (data-flow order).
  std::function<void(const std::string&)> before_read;

 private:
  std::unique_ptr<Scope> make_scope(const Pou& pou, const std::string& path, int depth);
  std::unique_ptr<Var> make_var(const Variable& decl, const std::string& path, int depth, bool in_function);
  std::unique_ptr<Var> hmi_var(std::unique_ptr<Var> v, bool in_function);
  void place_channel(FlatBlock& b, const Var& v);
  void finalize(Scope& s);
  void finalize_var(Var& v);
  bool written(const Var& v) const;  // some body assigns it
  // Whether %Q variable `v` drives its output (not when an alias at the same
  // address that the program writes does).
  bool drives_output(Var& v);
  // The declaration with its data type resolved: an alias or a subrange to its
  // base, an enumeration to INT with its values as integers.
  const Variable& resolved_decl(const Variable& decl);
  // Members of a structure, elements of an array, with their initial values.
  void make_members(Var& v, const Variable& decl, const DataType& t, int depth, bool in_function);
  void make_elements(Var& v, const Variable& decl, std::shared_ptr<const ArrayType> a, const XmlElement* init,
                     int depth, bool in_function);
  Value start_value(Var& v, SourcePos pos);
  void emit_channel(Var& v);
  // `x` as it was at the last cycle `run` held (a block named `name` that
  // reads itself): what a standard FB that is not called keeps.
  Value hold(const Value& run, const Value& x, const std::string& name, SourcePos pos);
  // Standard FB `v` called in the cycles `run` holds, inputs by formal position.
  void lower_std_fb(Var& v, const Value& run, std::vector<std::optional<Value>> placed, SourcePos pos);

  const Project& proj_;
  Emitter em_;
  DiagnosticList& d_;
  CheckedProgram& out_;
  std::unique_ptr<Scope> globals_;
  std::vector<std::unique_ptr<Scope>> programs_;
  std::vector<Var*> all_vars_;
  struct EdgeMemory {
    Value value;
    std::string name;
    SourcePos pos;  // the edge's place in the file, for --explain
  };
  std::vector<EdgeMemory> edge_memories_;
  std::vector<std::unique_ptr<Scope>> function_scopes_;
  std::vector<std::string> written_;  // upper-case names written by the program bodies
  int call_depth_ = 0;
  std::vector<std::map<const Var*, LoopHome>> loops_;  // per real loop, innermost last: its homes
  // The plain one-dimensional array `path` ("a[#1]") names, when a loop is
  // being lowered and its index is not a constant (then in `index_value`).
  Var* indexed_array(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                     SourcePos pos, Value& index_value);
  // `value` as variable `v` holds it: its kind, and wrapped into its integer type.
  Value coerce(Var& v, Value value, SourcePos pos);
  size_t elements_ = 0;
  std::vector<const Var*> outputs_;  // %Q variables that drive their output
  std::vector<std::pair<uint32_t, std::string>> hmi_addresses_;  // HMI variables' channels (hmi_var)
  std::optional<Value> il_result_;  // array elements made so far, at most kMaxArrayElements
  std::vector<std::unique_ptr<Variable>> owned_decls_;  // function result variables
  struct PendingOutput {
    Var* fb;
    std::string name;
    SourcePos pos;
  };
  std::vector<PendingOutput> pending_outputs_;  // FB outputs read by name
  // The steps of the chart a scope's SFC body holds: upper-case name -> the
  // block of its flag (`S.X` reads it; sfc.cpp).
  std::map<const Scope*, std::map<std::string, std::string>> chart_steps_;
  // The elapsed time `S.T` reads of the steps whose `.T` the POU mentions:
  // upper-case name -> its value where it is read (sfc.cpp, step_times).
  struct StepTime {
    std::string step;  // as the chart spells it
    Value now;         // what `S.T` reads here
  };
  std::map<const Scope*, std::map<std::string, StepTime>> step_times_;
  // `S.X` or `S.T` of a step of `s`'s chart: its value; nullopt when `path`
  // names no step.
  std::optional<Value> step_member(Scope& s, const std::string& path, SourcePos pos);
  void step_times(Scope& s, const XmlElement& body, const sfc::Chart& chart, const sfc::HostLink& host);
  void stamp_step_times(Scope& s, const sfc::HostLink& host, bool entered_reads_zero);
  std::vector<std::string> produced_;           // FB output blocks made
  struct PathCond {
    Value cond;
    bool negated = false;
    std::optional<Value> conj;  // this and every outer condition, made when first asked
  };
  std::vector<PathCond> path_;
  struct GatheredCall {
    Value run;
    std::vector<std::optional<Value>> placed;
  };
  std::map<const Var*, std::vector<GatheredCall>> gathered_;
  std::map<const Var*, size_t> gathered_floor_;  // calls noted before the branch being lowered
  std::string trigger_;
  SourcePos trigger_pos_;
  EditorSemantics semantics_ = EditorSemantics::kMatiec;
  std::set<const Pou*> lowered_pous_;
  std::set<const Var*> written_inputs_;  // inputs the program writes (noted once each)
  // inst.ENO of function block instances (eno_var), made when first named.
  Var& eno_var(const Var& fb);
  std::map<const Var*, std::unique_ptr<Var>> eno_vars_;
};

// A path as the user wrote it, near enough: "a[#1].x" -> "a[...].x".
std::string path_text(const std::string& path);

// The variables a name may denote: a plain variable, or every element or
// member of the array, structure or FB instance `v` (not a standard FB's).
void var_leaves(Var& v, std::vector<Var*>& out, std::set<const Var*>& seen);

// Upper-case names a POU body assigns (ST `x :=`, FBD/LD outVariable and coil
// targets): a located %M variable nobody writes is an operator set-point.
void collect_written(const Pou& p, std::vector<std::string>& out);

std::optional<Location> parse_location(const std::string& address, std::string* error);

// Function calls and FB instances nest at most this deep (recursion is an error).
inline constexpr int kMaxNesting = 16;

inline bool integer_type(BaseType b) {
  return b != BaseType::kDerived && iec::type_info(iec_type(b)).integer;
}

}  // namespace rtplc::lang::plcopen
