// Internal to the FBD front end (lang/macro_expander.cpp, lang/fbd_arguments.cpp):
// the scopes of a macro expansion and the binding of one primitive call's written
// arguments. Spec fbd-language.md, "Blocks and ids" and "Macros".
//
// F and D ids (M and N inside a macro) are separate names: F5 and D5 may both
// exist. The letter is part of the name and fixes the kind, so "F used where D is
// needed" is decided by the letter and a reference always finds a block of the
// kind it names.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "blocks/registry.h"
#include "common/diagnostic.h"
#include "lang/ast.h"
#include "lang/flat_program.h"

namespace rtplc::lang::fbd {

inline bool is_analog_letter(char l) {
  return l == 'F' || l == 'M';
}
inline bool is_value_letter(char l) {
  return l == 'F' || l == 'D' || l == 'M' || l == 'N';
}
inline Kind letter_kind(char l) {
  return is_analog_letter(l) ? Kind::kAnalog : Kind::kDigital;
}
inline char top_letter(Kind k) {
  return k == Kind::kAnalog ? 'F' : 'D';
}
inline char macro_letter(Kind k) {
  return k == Kind::kAnalog ? 'M' : 'N';
}

inline uint64_t id_key(Kind k, uint32_t n) {
  return (uint64_t{k == Kind::kDigital} << 32) | n;
}

// What an id names in one scope.
struct Binding {
  enum class What : uint8_t { kBlock, kAlias, kPoison };
  What what = What::kBlock;
  uint32_t flat = 0;     // kBlock
  int alias_scope = -1;  // kAlias
  Ref alias_ref;         // kAlias
  SourcePos pos;         // where the name was introduced
  bool is_formal = false;
};

struct ParamBinding {
  bool known = false;  // false while dry-checking an uncalled macro
  double value = 0;
};

// The program body, or one macro call's expansion. Formals are aliases of the
// caller's arguments; names are resolved after the whole program is expanded.
struct Scope {
  int parent = -1;
  bool top = true;
  std::string prefix;  // name prefix for blocks of this expansion ("F10.")
  uint32_t call_line = 0;
  SourcePos call_pos;
  std::string macro;  // macro name, for notes
  std::unordered_map<uint64_t, Binding> ids;
  std::unordered_map<uint32_t, ParamBinding> params;
};

// An input reference waiting for resolution: slot `slot` of flat block `block`.
struct PendingInput {
  uint32_t block;
  uint32_t slot;
  int scope;
  Ref ref;
};

// Where a call's arguments are bound: the scope they are written in, and the
// list that collects its input references (resolved after expansion).
struct ArgumentContext {
  const Scope& scope;
  int scope_index;
  std::vector<PendingInput>& staged;
  DiagnosticList& diags;
};

// Binds the written arguments of primitive call `c` to `b` (whose `spec` is set):
// inputs (by letter and scope), literal or macro parameters, device addresses,
// labels. Reports each problem at its argument and returns false on any error.
bool bind_call_arguments(const Call& c, const ArgumentContext& ctx, FlatBlock& b);

// A literal parameter, or P<n> inside a macro. `known` is false for a parameter
// of a macro dry-checked without a call. Returns false (after reporting) on error.
bool bind_parameter(const Arg& a, const ArgumentContext& ctx, const ParamSpec& ps,
                    const char* block, double& out, bool& known);

}  // namespace rtplc::lang::fbd
