// PNML (ISO/IEC 15909-2) import and export of P/T nets, the 2009 grammar that the
// Model Checking Contest uses (issue item 3, "PNML").
//
// Read: the first <net> of the document, whose type must be the P/T net type;
// other net types (symmetric/coloured, high-level) are refused by name. Nested
// pages are flattened; referencePlace / referenceTransition nodes stand for the
// node they name; arcs may name nodes declared later; a missing inscription or
// initial marking means 1 or 0 tokens; <graphics>, <toolspecific> and any other
// element the P/T grammar does not use are skipped. Every error has a line:col.
//
// Write: one page, ids as in the net, labels as names, weights other than 1 as
// inscriptions. A read arc (p <-> t) becomes two arcs, p -> t and t -> p.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "common/diagnostic.h"
#include "lang/petri/net.h"

namespace rtplc::petri {

inline constexpr std::string_view kPtNetType = "http://www.pnml.org/version-2009/grammar/ptnet";

struct PnmlReadResult {
  std::optional<Net> net;
  DiagnosticList diags;
};

PnmlReadResult read_pnml(std::string_view text);

std::string write_pnml(const Net& net);

}  // namespace rtplc::petri
