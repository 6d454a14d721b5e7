// The name rules of an SFC program (docs/sfc.md, "Names and rules"): what both
// back ends — the flat-block builder (builder.h) and the net builder
// (net_builder.h) — need to hold before they translate a chart. One pass
// reports every broken rule with its position and builds the look-up tables.
#pragma once

#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/diagnostic.h"
#include "lang/sfc/ast.h"

namespace rtplc::lang::sfc {

struct PlaceRef {
  size_t module = 0;
  size_t place = 0;
};

struct ChartIndex {
  std::unordered_map<std::string, size_t> steps;    // name -> Chart::steps index
  std::unordered_map<std::string, size_t> signals;  // name -> Chart::signals index
  std::unordered_map<std::string, size_t> transitions;
  std::unordered_map<std::string, size_t> modules;
  std::unordered_map<std::string, PlaceRef> places;
  // Per step: the transitions leaving and entering it, in text order.
  std::vector<std::vector<size_t>> leaving, entering;
};

// "Fill.X" -> "Fill"; "" when `name` does not end in ".X".
std::string step_of_flag(const std::string& name);

// Checks names, references, qualifiers and the plant model; errors and
// warnings go to `diags`. The index is complete only when there are no errors.
ChartIndex check_chart(const Chart& chart, DiagnosticList& diags);

// Quoted closest candidate for "did you mean", or "".
std::string closest_name(const std::string& name, const std::vector<std::string>& candidates);

}  // namespace rtplc::lang::sfc
