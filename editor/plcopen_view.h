// A PLCopen project as the editor shows it, read-only (docs/editor.md,
// "SFC and PLCopen"): every POU, and for each graphical body (FBD, LD, SFC)
// its elements with the positions the project gives them and the connections
// between them; ST and IL bodies as their text. The project is read by the
// PLCopen front end's own reader (lang/plcopen/project.h): what it refuses,
// this refuses with the same message.
#pragma once

#include <string_view>

#include <nlohmann/json.hpp>

#include "common/result.h"

namespace rtplc::editor {

// {"pous": [{"name", "type" (program, functionBlock, function), "language",
//   "source" (ST/IL), "positioned" (false when the project put every element
//   at one point, as some editors do: the page then lays them out by flow),
//   "elements": [{"id", "element" (block, inVariable, step, contact, ...),
//   "label", "type", "instance", "x", "y", "w", "h", "depth",
//   "inputs": [{"pin", "from", "from_pin", "negated"}], "outputs": [pin]}]}]}
// A project that does not read: the reader's diagnostics rendered against `file`.
Result<nlohmann::json> plcopen_view(std::string_view xml, const std::string& file = "project.xml");

}  // namespace rtplc::editor
