// SFC -> the language-neutral flat program (docs/sfc.md, "How an SFC runs";
// lang/flat_program.h). An SFC program becomes ordinary primitive blocks:
// steps are latches built from or/and/not with a one-cycle delayed reference,
// transitions are and/or/not over the previous cycle's step flags, action
// qualifiers are made of the same gates and the `time` on-delay timer. The
// result then goes through check_flat_program() and build_image() exactly
// like an FBD program, so the executor, the runtime, hot swap and the monitor
// need nothing new.
#pragma once

#include <string_view>

#include "common/diagnostic.h"
#include "lang/flat_program.h"
#include "lang/sfc/ast.h"
#include "lang/sfc/semantics.h"

namespace rtplc::lang::sfc {

// The processor address of the step flags: step i of a chart whose header says
// `STEPS d<m>` is the ddo channel p255.d<m>.c<i>, labelled "<chart>.<step>".
inline constexpr uint16_t kStepFlagProcessor = 255;

// Translates a chart that passed check_chart() without errors.
CheckedProgram build_flat_program(const Chart& chart, const ChartIndex& index,
                                  DiagnosticList& diags);

// The whole SFC front end: text -> tokens -> chart -> name rules -> flat
// program. The caller runs check_flat_program() and build_image() when `diags`
// has no errors.
CheckedProgram compile_to_flat(std::string_view source, DiagnosticList& diags);

// Parses and checks the names only (what `rtplc analyze` needs); `ok` false on errors.
Chart parse_chart(std::string_view source, DiagnosticList& diags, ChartIndex* index, bool* ok);

}  // namespace rtplc::lang::sfc
