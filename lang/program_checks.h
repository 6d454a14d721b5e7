// The language-neutral checks of a flat program (lang/flat_program.h): what the
// spec fbd-language.md ("Blocks and ids", "Execution order and delays",
// "Devices and labels", "Errors") requires of any list of primitive blocks,
// whatever language it was written in. Every front end calls
// check_flat_program() after producing its flat blocks; the block rules below it
// are also public so a front end that checks arguments where they are written
// (FBD points at each argument) states each rule with the same words.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "blocks/registry.h"
#include "common/diagnostic.h"
#include "lang/flat_program.h"

namespace rtplc::lang {

// ---- the entry point for front ends ----

// Checks `p` and completes it for the compiler. A front end fills, per block:
// `written` (or `spec`), `name` (unique; may be empty for an output block),
// `pos`, `call_line` (0 for a block the user wrote directly), `n_in`, `in` (the
// producer's index), `in_pos`, `params` (the literals given; omitted trailing
// ones get their defaults), and for I/O blocks `p`, `d`, `c`, `label` (empty:
// a default one) and `init`.
//
// Reports, in block order: unknown block, wrong arity, an input naming no block
// or a block without an output, an input of the wrong kind (analog/digital),
// parameters out of range, device addresses out of range, bad labels, a digital
// set-point starting neither at 0 nor 1, missing or duplicate names. Then, over
// the whole program: one writer per output channel, one definition per
// set-point, one channel per label, compute results nobody reads (a warning,
// for blocks with call_line 0, only when there is no error), and the block
// limit. On success every block has `spec`, `op`, `delayed` and its defaults
// set; the result is meaningful only when `diags` has no errors.
void check_flat_program(CheckedProgram& p, DiagnosticList& diags);

// ---- the whole-program phases, for a front end that must interleave its own
// diagnostics with them (the FBD checker keeps its historical order). Each
// expects blocks whose `spec`, `n_in` and `in` are set. ----

// delayed[k] = the input reads a block at or after its reader: last cycle's value.
void mark_delayed_inputs(CheckedProgram& p);

// Control-flow blocks: a set writes a var of its kind, a jmp/jz/jnz jumps
// forward, a loop backward (FlatBlock::target).
void check_flow(const CheckedProgram& p, DiagnosticList& diags);

// One writer per output channel; one definition per set-point; a label names one
// channel (it is how `rtplc set` and the CSV header find it).
void check_io_channels(const CheckedProgram& p, DiagnosticList& diags);

// A `good` block's input is a device input block: the channel whose quality it reads.
void check_quality_inputs(const CheckedProgram& p, DiagnosticList& diags);

// Warns about compute blocks with call_line 0 that no block reads. Silent when
// `diags` already has errors (an unresolved input would look like an unused one).
void warn_unused_results(const CheckedProgram& p, DiagnosticList& diags);

// The program must fit the runtime's capacity (RTPLC_MAX_BLOCKS).
void check_program_size(const CheckedProgram& p, DiagnosticList& diags);

// ---- block rules, one definition each ----

// "; did you mean 'filt'?" or " (rtplc blocks lists all ...)", to follow
// "unknown block 'x'".
std::string unknown_block_hint(std::string_view name);

// "sub takes sub(a, b, [k]), found 1 argument".
std::string arity_message(const BlockSpec& spec, size_t found);

// The argument form of an I/O block: "(p, d, c, \"label\")" and the like.
const char* io_form(const BlockSpec& spec);

// Empty if `value` is allowed for `ps`, else "parameter 'Ti' (...) of intg must be
// greater than 0, found 0".
std::string parameter_error(const ParamSpec& ps, const char* block, double value);

// Empty unless the block's literal parameters contradict each other
// (lim: lower above upper). `params` holds every parameter, defaults filled in.
std::string parameter_relation_error(const BlockSpec& spec, const std::vector<double>& params);

// Device address bounds: p and d are 0..255, c is 0..65535.
inline constexpr uint32_t kMaxProcessor = 255;
inline constexpr uint32_t kMaxModule = 255;
inline constexpr uint32_t kMaxChannel = 65535;
// Empty if `number` fits address letter `letter` (p, d or c), else the message.
std::string device_range_error(char letter, uint32_t number);

// Empty if `label` may name a channel (1 to 31 of letters, digits, _ - .).
std::string label_error(std::string_view label);

// A digital set-point starts at 0 or 1.
bool setpoint_init_ok(const BlockSpec& spec, double init);
inline constexpr const char* kSetpointInitMessage = "a digital set-point starts at 0 or 1";

// "p0.d1.c2" (or "d1.c2" for a set-point), and the label used when none is given.
std::string device_text(const FlatBlock& b);
std::string default_label(const FlatBlock& b);

// "F1 is already defined (line 2): every block needs its own id".
std::string duplicate_name_message(const std::string& name, std::string_view what,
                                   uint32_t first_line);

}  // namespace rtplc::lang
