// The PLCopen lowering's output side (docs/plcopen.md, "How a POU becomes
// blocks"): values, constants, and the primitive blocks that compute them,
// appended to a CheckedProgram in execution order. Inputs are block names,
// resolved once every block exists, so a reference to a block appended later
// reads last cycle's value (the one-cycle rule of every front end).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "lang/flat_program.h"
#include "lang/iec/iec_types.h"

namespace rtplc::lang::plcopen {

// A value during lowering: the block producing it, or a constant.
struct Value {
  std::string ref;  // producing block's name; empty for a constant
  bool digital = false;
  bool integer = false;  // an integer-typed value (DIV truncates)
  // An integer value's IEC type when it is known (a variable's; a literal
  // has none and takes the other operand's): the operand type of a standard
  // function (lang/iec), so AND on INT works on 16 bits.
  std::optional<iec::IecType> int_type;
  // A TIME, DATE, TOD or DT value's type when it is known (a variable's, a
  // function's result): what the third edition's TO_DINT(t) converts from.
  std::optional<iec::IecType> time_type;
  bool is_const = false;
  double k = 0;
  // A STRING (docs/st.md, "Strings"): the longest text it may hold, and a
  // constant's text.
  bool str = false;
  bool wide = false;  // a WSTRING: UTF-16 code units; `text` is their UTF-8
  uint32_t cap = 0;
  std::string text;
  bool valid() const { return is_const || !ref.empty(); }
};

Value constant(double k, bool digital);
Value string_constant(std::string text, bool wide = false);

enum class BinOp : uint8_t {
  kAdd, kSub, kMul, kDiv, kMod, kExpt, kAnd, kOr, kXor, kEq, kNe, kLt, kLe, kGt, kGe
};

class Emitter {
 public:
  Emitter(CheckedProgram& p, DiagnosticList& d) : p_(p), d_(d) {}

  // Appends a block whose inputs are names. Returns its index.
  size_t emit(const std::string& written, std::string name, SourcePos pos,
              std::vector<std::string> ins, std::vector<double> params = {});
  FlatBlock& block(size_t i) { return p_.blocks[i]; }
  // Appends a control-flow block (registry.h flow_block: var, dvar, set, dset,
  // jmp, jz, jnz, loop) aimed at block index `target`. Returns its index.
  size_t emit_flow(const char* written, std::string name, SourcePos pos, std::vector<std::string> ins,
                   uint32_t target, std::vector<double> params = {});
  // A pick/dpick or put/dput block: `table` names the blocks (resolved by
  // finish() like inputs), `lo` the index of the first.
  size_t emit_indexed(const char* written, std::string name, SourcePos pos, std::vector<std::string> ins,
                      std::vector<std::string> table, double lo);
  // Takes over blocks from `first` on that someone else appended with input
  // indices (lang/iec's lowering): `input_name` names each input's producer,
  // resolved by finish() like every other reference.
  void adopt(size_t first, const std::function<std::string(uint32_t)>& input_name);
  // Appends a block whose inputs are already indices (one another front end
  // built, lang/sfc for an SFC body); later blocks may read it by name.
  void append_resolved(FlatBlock b);
  // Appends a block another builder made, its inputs given by name (resolved
  // by finish(), like emit()'s).
  void append_named(FlatBlock b, std::vector<std::string> ins);
  size_t size() const { return p_.blocks.size(); }

  // A unique name under `scope` ("main" -> "main.$7").
  std::string fresh(const std::string& scope);

  // True when `ref` names one of the last few blocks and that block is
  // written` with these params (a value that is already wrapped into a type).
  bool recent_block_is(const std::string& ref, const char* written, const std::vector<double>& params) const;

  // The block name holding `v` (constants become blocks, shared by value).
  std::string ref(const Value& v, SourcePos pos);

  Value to_analog(const Value& v, SourcePos pos);
  Value to_digital(const Value& v, SourcePos pos);
  Value unary_not(const Value& v, SourcePos pos);
  Value negate(const Value& v, SourcePos pos);
  Value binary(BinOp op, const Value& a, const Value& b, SourcePos pos);
  // cond ? a : b
  Value select(const Value& cond, const Value& a, const Value& b, SourcePos pos);
  // A copy of `v` in a block named `name` (the variable's value at the end of
  // the cycle; always the same opcode per kind, so hot swap keeps it).
  // A STRING's copy holds at most `cap` characters (its variable's length).
  void copy_as(const Value& v, const std::string& name, SourcePos pos, uint32_t cap = 0);
  // A string block (registry.h flow_block: sconst ... sset) on `ins`; its
  // value, a WSTRING when `wide`.
  Value string_block(const char* written, const std::string& stem, SourcePos pos, std::vector<std::string> ins,
                     std::vector<double> params, uint32_t cap, bool wide = false);
  // String `v` holding at most `cap` characters: a constant cut here, any
  // other value through an scopy.
  Value cut_string(const Value& v, uint32_t cap, SourcePos pos);

  // 1 in the task's first cycle only (initial values).
  Value first_cycle(SourcePos pos);

  // True when this build has the block (the IEC blocks arrive separately).
  bool has_block(const char* name) const;
  // Reports that `what` needs block `block`, once per block name.
  void missing_block(const char* block, const std::string& what, SourcePos pos);

  // Appends the closing blocks and resolves every reference; false on an
  // unresolved name (a lowering bug, reported as such).
  bool finish();

  DiagnosticList& diags() { return d_; }

 private:
  CheckedProgram& p_;
  DiagnosticList& d_;
  std::vector<std::vector<std::string>> refs_;  // per block its input names
  std::vector<bool> resolved_;                  // per block: in[] set by append_resolved
  std::map<size_t, std::vector<std::string>> tables_;  // pick/put blocks: their table by name
  std::map<std::string, std::string> consts_;
  std::map<std::string, bool> reported_missing_;
  size_t counter_ = 0;
  bool first_made_ = false;
};

}  // namespace rtplc::lang::plcopen
