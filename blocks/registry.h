// The block registry: every primitive block of the FBD language (spec
// fbd-language.md, "The primitive blocks"), its signature, parameters, state and
// contract. It is the single source of truth: the compiler reads names, arity,
// kinds and parameter checks from here, the executor's opcodes come from here,
// and docs/blocks.md is generated from it (`rtplc blocks --markdown`).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "blocks/ops.h"

namespace rtplc {

// kString: a text (ops.h, "Strings"), only in the textual languages' blocks.
enum class Kind : uint8_t { kAnalog, kDigital, kString };

enum class BlockGroup : uint8_t { kInput, kOutput, kArithmetic, kLogic, kControl, kIec };

// Where an I/O block's data comes from (the seed's five data kinds).
enum class IoGroup : uint8_t { kNone, kDio, kEpc, kPlc, kEth, kSetp };

// How a call's arguments are laid out.
enum class Signature : uint8_t {
  kCompute,    // inputs..., params...           e.g. add(F1, F2, 2)
  kDeviceIn,   // (p, d, c, "label")             e.g. dai(p0, d0, c0, "PV")
  kSetpoint,   // (d, c, init, "label")          e.g. asp(d0, c0, 50, "SP")
  kDeviceOut,  // (value, p, d, c, "label")      e.g. dao(F10, p0, d0, c0, "MV")
};

// A numeric parameter of a compute block. Checks run at compile time on the
// literal (after macro parameters are substituted), so the executor never sees a
// value outside these bounds.
struct ParamSpec {
  const char* name;
  const char* meaning;
  double default_value;  // used when the argument is omitted (only trailing params)
  bool optional;
  double min;            // inclusive bounds
  double max;
  bool min_exclusive;    // min itself not allowed (e.g. T > 0)
  bool integer;
};

struct BlockSpec {
  const char* name;
  const char* alias;  // second accepted spelling or nullptr (derv/deriv)
  BlockGroup group;
  Signature signature;
  IoGroup io;
  char device_kind;    // PLC device letter X/Y/M/R, 0 otherwise
  bool has_output;     // false for output blocks (no ID =)
  Kind out_kind;
  uint8_t min_inputs;
  uint8_t max_inputs;
  Kind input_kind[3];
  const char* input_names[3];
  uint8_t param_count;
  ParamSpec params[8];
  const char* state;    // what it remembers between cycles, "" if nothing
  const char* summary;  // one line
  const char* contract; // formula and edge behaviour
  const char* errors;   // what counts as an error, "" if none
  // Reads the quality of the channel its input block reads, not a value: its
  // input must be a device input block, of either kind (the `good` block).
  bool reads_quality = false;
};

std::span<const BlockSpec> all_blocks();

// Looks a block up by name or alias; nullptr if unknown.
const BlockSpec* find_block(std::string_view name);

// A control-flow block (var, dvar, set, dset, jmp, jz, jnz, loop, pick, dpick,
// put, dput) or string block (sconst, scopy, ssel, scat, sleft, sright, smid,
// sins, sdel, slen, sfind, scmp, sfmt, sparse, svar, sset) for the textual
// front ends; nullptr if unknown. Never found by find_block().
const BlockSpec* flow_block(std::string_view name);

// Closest known block name (for "did you mean"), empty if nothing is close.
std::string suggest_block(std::string_view name);

// The executor opcode that implements `spec` when called with `n_inputs` inputs.
Op block_op(const BlockSpec& spec, uint32_t n_inputs);

const char* group_name(BlockGroup g);
const char* io_group_name(IoGroup g);
const char* kind_name(Kind k);

// Derives the prepared coefficients an instruction reads (ops.h, column P) from
// the literal parameters and the task period `dt` (seconds). `out` must hold
// op_param_count(op) doubles.
void prepare_params(Op op, std::span<const double> literal, double dt, double* out);

// docs/blocks.md, generated from the registry.
std::string blocks_markdown();

}  // namespace rtplc
