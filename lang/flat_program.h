// The language-neutral intermediate form: a flat list of primitive blocks in
// execution order, every input an index of the block that produces it. Every
// front end (the FBD macro expander today; SFC and PLCopen XML next) produces
// it, lang/program_checks.h checks it, lang/compiler.h turns it into a
// TaskImage. Nothing here knows about FBD syntax or macros (spec
// fbd-language.md, "Execution order and delays" and "Devices and labels" are
// the rules it carries).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "blocks/registry.h"
#include "common/diagnostic.h"

namespace rtplc::lang {

struct FlatBlock {
  const BlockSpec* spec = nullptr;  // nullptr: looked up from `written` by the checks
  Op op = Op::Add;
  std::string name;        // "F10", "F10.M4" inside an expansion, "dao@p0.d0.c0" for outputs
  std::string written;     // block name as written ("deriv")
  SourcePos pos;           // the statement
  uint32_t call_line = 0;  // outermost macro call site, 0 at top level
  uint32_t n_in = 0;
  uint32_t in[3] = {0, 0, 0};               // producer indices in CheckedProgram::blocks
  bool delayed[3] = {false, false, false};  // reads last cycle's value
  SourcePos in_pos[3];
  std::vector<double> params;  // literal parameters, defaults filled in
  // Control-flow blocks (registry.h, flow_block): for set/dset the var or dvar
  // block it writes; for jmp/jz/jnz/loop the block execution continues at
  // (blocks.size() = the end of the cycle). Forward for jmp/jz/jnz, at or
  // before the branch for loop.
  uint32_t target = 0;
  // pick/dpick: the blocks whose values it chooses among; put/dput: the var or
  // dvar blocks it writes into (element k for index lo + k, lo = params[0]).
  std::vector<uint32_t> table;
  // I/O blocks
  uint16_t p = 0, d = 0;
  uint32_t c = 0;
  std::string label;
  double init = 0;
  bool hmi = false;  // an HMI variable's channel (Binding kBindingHmi)
};

struct CheckedProgram {
  std::vector<FlatBlock> blocks;  // textual order = semantic execution order
  double period = 0.1;            // seconds
  bool period_from_stime = false;  // the program set its period (at stime_pos)
  SourcePos stime_pos;
  const char* period_source = "stime";  // what set it, for --explain ("task interval")
  uint32_t macro_calls = 0;
  // What a front end decided that the blocks alone do not show (a PLCopen
  // feedback loop broken at a connection); `check --explain` lists them.
  std::vector<std::string> notes;
  // Blocks holding a source variable's value at the end of the cycle, named
  // as the user knows it ("instance0.level"): `rtplc sim` traces each as a
  // CSV column. Empty for FBD, where every block is already named.
  std::vector<std::string> variables;
};

inline constexpr double kDefaultPeriod = 0.1;

}  // namespace rtplc::lang
