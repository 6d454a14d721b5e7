// Entry points into the FBD and LD graph lowering (graph.cpp) for SFC
// transition conditions drawn graphically (sfc.cpp; docs/plcopen.md, "SFC").
// The same lowering as an FBD or LD body; what differs is where the value
// comes out: at an element outside the graph, or at the element that names
// the transition.
#pragma once

#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "common/xml_reader.h"
#include "lang/plcopen/emitter.h"

namespace rtplc::lang::plcopen {

class Lowering;
struct Scope;

// Lowers the FBD and LD elements drawn in SFC body `sfc` (its SFC elements are
// skipped) once, and returns the value reaching each of `points`, the
// <connectionPointIn> of transition conditions in that body, in order. A point
// nothing is connected to gives an invalid Value; after an error, all do.
std::vector<Value> lower_sfc_graph_inputs(Lowering& L, Scope& s, const XmlElement& sfc,
                                          const std::vector<const XmlElement*>& points);

// Lowers an FBD or LD transition body (inline or in the POU's <transitions>)
// whose value is written to `name`, the transition's name: by the one
// outVariable or coil naming it, which assigns no variable; in LD without
// one, what reaches the single right power rail. `what` names the transition
// in errors ("transition 'full'"), at `pos` when no element is to blame.
// Invalid after an error.
Value lower_graph_result(Lowering& L, Scope& s, const XmlElement& body, bool ladder,
                         const std::string& name, const std::string& what, SourcePos pos);

}  // namespace rtplc::lang::plcopen
