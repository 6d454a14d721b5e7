// SFC -> the language-neutral flat program (docs/sfc.md, "How an SFC runs";
// lang/flat_program.h). An SFC program becomes ordinary primitive blocks:
// steps are latches built from or/and/not with a one-cycle delayed reference,
// transitions are and/or/not over the previous cycle's step flags, action
// qualifiers are made of the same gates and the `time` on-delay timer. The
// result then goes through check_flat_program() and build_image() exactly
// like an FBD program, so the executor, the runtime, hot swap and the monitor
// need nothing new.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "common/diagnostic.h"
#include "lang/flat_program.h"
#include "lang/sfc/ast.h"
#include "lang/sfc/semantics.h"

namespace rtplc::lang::sfc {

// The processor address of the step flags: step i of a chart whose header says
// `STEPS d<m>` is the ddo channel p255.d<m>.c<i>, labelled "<chart>.<step>".
inline constexpr uint16_t kStepFlagProcessor = 255;

// A chart built into another front end's program (the PLCopen importer,
// docs/plcopen.md "SFC"): the chart's blocks are appended to the host's
// program at `first_index`, its kHost signals are blocks of the host, and the
// host reads each OUTPUT's action flag (action_flag_block) to drive its own
// variables and action bodies. Step flags get no ddo channel: the host shows
// them its own way.
struct HostLink {
  std::string prefix;        // before every block name the chart makes: "fill0.sfc."
  uint32_t first_index = 0;  // the host program's size when the chart's blocks are appended
  // The host block holding a kHost signal's value; nullopt is reported as undefined.
  std::function<std::optional<uint32_t>(const std::string& name)> resolve;
  // The order of one cycle (docs/plcopen.md, "Which editor's semantics"):
  //  - transitions first (MatIEC: Beremiz, OpenPLC; the .sfc language): the
  //    transitions from last cycle's step flags, the new flags, then the
  //    actions of the steps active now, so a step's actions start in the
  //    cycle it is entered;
  //  - actions first (CODESYS): the actions of the steps active at the start
  //    of the cycle, then the transitions from those steps (seeing what the
  //    actions did), and the new flags for the next cycle. The chart's blocks
  //    are then two parts: the actions' flags (the first `actions_end` blocks,
  //    which the host follows with the action bodies and the conditions), then
  //    the transitions and steps.
  bool actions_first = false;
};

// The block holding step `step`'s flag (this cycle's) and the OR of the
// actions driving OUTPUT `output`, as a host program names them.
std::string step_flag_block(const HostLink& host, const std::string& step);
std::string action_flag_block(const HostLink& host, const std::string& output);

// Translates a chart that passed check_chart() without errors. With `host`,
// block names carry its prefix and inputs are indices in the host's program.
// With host->actions_first, `actions_end` receives the size of the first part.
CheckedProgram build_flat_program(const Chart& chart, const ChartIndex& index,
                                  DiagnosticList& diags, const HostLink* host = nullptr,
                                  size_t* actions_end = nullptr);

// The whole SFC front end: text -> tokens -> chart -> name rules -> flat
// program. The caller runs check_flat_program() and build_image() when `diags`
// has no errors.
CheckedProgram compile_to_flat(std::string_view source, DiagnosticList& diags);

// Parses and checks the names only (what `rtplc analyze` needs); `ok` false on errors.
Chart parse_chart(std::string_view source, DiagnosticList& diags, ChartIndex* index, bool* ok);

}  // namespace rtplc::lang::sfc
