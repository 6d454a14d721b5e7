// The IEC 61131-3 standard functions and function blocks, and how each call
// lowers to primitive blocks (docs/language.md, "IEC 61131-3 types and
// standard blocks"). One table: the PLCopen importer resolves a block's
// typeName with find_iec(), connects its formal inputs by position in
// `inputs`, and reads each formal output from the index lower() returns.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.h"
#include "lang/iec/emitter.h"
#include "lang/iec/iec_types.h"

namespace rtplc::lang::iec {

struct IecCall {
  // Producer index per formal input, in the order of IecFunction::inputs
  // (kUnconnected: the IEC default, 0 / FALSE). An extensible function (ADD,
  // MUX, ...) takes as many as are given, at least `min_inputs`.
  std::vector<uint32_t> inputs;
  // The operand type of an overloaded function (ADD on INT wraps, AND on WORD is
  // bitwise, SHL needs a bit string); REAL when the caller does not know.
  IecType type = IecType::kReal;
  // Which formal outputs are used (empty: all). An unused one may be left out
  // (kUnconnected in the result): TON's ET costs a block only when wired.
  std::vector<bool> wanted;
};

struct IecFunction;
using IecLower = Result<std::vector<uint32_t>> (*)(const IecFunction& f, Emitter& e,
                                                   const IecCall& call);

struct IecFunction {
  std::string name;                  // upper case: "TON", "INT_TO_REAL"
  bool function_block;               // has state: one instance per call site
  std::vector<const char*> inputs;   // formal names, in order ("IN", "PT")
  std::vector<const char*> outputs;  // formal names ("Q", "ET"); functions: "OUT"
  bool extensible;                   // IN1..INn: more inputs than listed
  uint32_t min_inputs;
  IecLower lower;
  const char* lowers_to;  // the primitives, for the docs
  // Conversions and typed variants (CTU_DINT) fix their types here.
  IecType from = IecType::kReal;
  IecType to = IecType::kReal;
  bool typed = false;
};

// Case-insensitive; nullptr if `name` is not a standard function or block rtplc
// supports. Conversions are every X_TO_Y of the elementary types, and TRUNC.
const IecFunction* find_iec(std::string_view name);

std::span<const IecFunction> all_iec_functions();

// Position of a formal input or output by name (case-insensitive), or -1. For
// an extensible function, IN<n> beyond the listed ones maps to its position.
int iec_input_index(const IecFunction& f, std::string_view formal);
int iec_output_index(const IecFunction& f, std::string_view formal);

// Whether formal input `k` decides the operand type of an overloaded call:
// not SEL's G, MUX's K or a shift's N (a selector or a count).
bool iec_input_sets_type(const IecFunction& f, size_t k);

// The type of `f`'s result called on operand type `type`: a conversion's
// target, TRUNC's integer (LINT on a REAL operand), else the operand type.
IecType iec_result_type(const IecFunction& f, IecType type);

// The kind of formal output `k` of `f` called on operand type `type`, as the
// lowering makes it (a front end typing a read of an FB output before the call).
Kind iec_output_kind(const IecFunction& f, size_t k, IecType type = IecType::kReal);

// The markdown table of docs/language.md's IEC section (generated, tested).
std::string iec_functions_markdown();

}  // namespace rtplc::lang::iec
