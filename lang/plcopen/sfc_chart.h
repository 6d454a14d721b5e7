// A PLCopen SFC body read as a chart of the SFC front end (docs/plcopen.md,
// "SFC"; lang/sfc/ast.h). The lowering (sfc.cpp) compiles the chart with
// lang/sfc's builder; `rtplc analyze` builds its Petri net with lang/sfc's net
// builder. Transition conditions stay PLCopen's: each is a host signal
// `$c<localId>` of the chart, and `transitions` keeps its XML element.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "common/xml_reader.h"
#include "lang/sfc/ast.h"

namespace rtplc::lang::plcopen {

// One action of an <actionBlock>: a qualifier on a variable or an action.
struct SfcActionUse {
  std::string qualifier;
  double duration = 0;  // seconds: L, D, SD, DS, SL
  std::string duration_variable;  // the duration given by a variable instead (`delay`, `a.b`)
  std::string target;   // a variable or an action name ("inline<id>@<block>" for an inline body)
  const XmlElement* inline_body = nullptr;
  SourcePos pos;
  size_t step = 0;  // index in SfcGraph::chart.steps
};

struct SfcGraph {
  sfc::Chart chart;
  std::vector<const XmlElement*> transitions;  // per chart transition, its <transition>
  std::vector<SfcActionUse> uses;              // in document order
  std::vector<std::string> targets;            // upper-case action targets, first use first
  // Durations given by variables: the chart's host signal ("$dur<n>") and the
  // use it is for (its duration_variable, pos).
  std::vector<std::pair<std::string, const SfcActionUse*>> durations;
};

// Reads `body` (the <SFC> element) into `g`: steps, transitions with the steps
// they leave and enter (through divergences, convergences and jumps), actions.
// False, with the reasons in `diags`, on a graph the chart cannot express.
bool read_sfc_graph(const XmlElement& body, const std::string& name, DiagnosticList& diags,
                    SfcGraph* g);

// `rtplc analyze FILE.xml`: the SFC body of POU `pou` of a PLCopen project
// (empty: the project's only POU with an SFC body) as a chart whose
// conditions, host signals without a plant MODEL, the net builder takes as
// free. nullopt, with the reasons in `diags`, when there is no such chart.
std::optional<sfc::Chart> read_sfc_pou(std::string_view xml, const std::string& pou,
                                       DiagnosticList& diags);
// The same for a project already read (a .st file's textual SFC, lang/st).
struct Project;
std::optional<sfc::Chart> read_sfc_pou(const Project& project, const std::string& pou, DiagnosticList& diags);

// The chart OUTPUT an action target becomes ("$" + upper-case name).
std::string sfc_output_name(std::string target);

}  // namespace rtplc::lang::plcopen
