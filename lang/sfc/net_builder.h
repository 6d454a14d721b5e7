// SFC -> hierarchical Petri net (spec petri-sfc.md, "SFC -> hierarchical PN",
// rules 1-4, and "Composition"; docs/sfc.md, "Analysis"), for `rtplc analyze`.
//
//   rule 1  every step is a place of the main loop, every SFC transition a
//           main-loop transition (a condition with OR becomes one transition per
//           alternative: T, T.2, ...); modules marked MAIN join the main loop.
//   rule 2  the sub-PN of a step is the set of plant modules its SUBNET line
//           names (default: the modules whose events read the step, and those
//           its leaving transitions read).
//   rule 3  an event `WHILE Step` reads the step's place (a read arc).
//   rule 4  a transition's condition reads the places its signals' MODEL
//           names: `LS2` reads the on-place, `NOT LS2` the off-place.
// Tokens never cross between the main loop and a sub-PN (read arcs only).
// Conditions on signals without a MODEL are left free (over-approximation:
// the environment may make them true), as are negated step flags and the
// priority between the branches of a selection divergence.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "lang/petri/compose.h"
#include "lang/petri/net.h"
#include "lang/sfc/ast.h"
#include "lang/sfc/semantics.h"

namespace rtplc::lang::sfc {

// One step's sub-PN as the paper writes it: its plant places (rows) and the
// events that move their tokens (columns), with its own incidence matrix and
// initial marking (eq. 10-14).
struct SubNet {
  std::string step;
  std::vector<std::string> modules;
  std::vector<std::string> places;
  std::vector<std::string> transitions;
  petri::IntMatrix b;
  petri::Marking initial;
  // The sub-PN on its own (no read arcs to the main loop): for state-equation stepping.
  petri::Net as_net() const;
};

struct SfcNet {
  petri::HierarchicalNet hierarchy{"sfc"};
  std::vector<SubNet> subnets;  // one per step, in step order
  // Modules for compose(): the main loop once, and every plant module once per
  // sub-PN that lists it (the paper's multiplicity D), plus unlisted ones once.
  std::vector<petri::Module> modules;
  const petri::Net& flat() const { return hierarchy.flat(); }
};

// Builds the net of a chart that passed check_chart() without errors. Reports
// conditions too large to expand (more than 64 alternatives).
std::optional<SfcNet> build_net(const Chart& chart, const ChartIndex& index, DiagnosticList& diags);

// Text -> net (lexer, parser, name rules, build_net).
std::optional<SfcNet> sfc_source_to_net(std::string_view source, DiagnosticList& diags);

// The SFC part of `rtplc analyze`'s report: the main loop, each sub-PN with its
// matrix, and whether the modules compose to the flat net's B.
std::string render_hierarchy(const SfcNet& net);

}  // namespace rtplc::lang::sfc
