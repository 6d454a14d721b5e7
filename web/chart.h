// The SFC view of the web console: a chart's steps and transitions as JSON,
// from the source the task runs (the operator API's `program` op), for the
// browser to draw. Which steps are active comes from the live stream: a step's
// flag is the channel labelled <chart>.<step> (docs/sfc.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string_view>

#include "common/result.h"

namespace rtplc::web {

// {"chart": NAME, "steps": [{"name", "label", "initial", "actions": ["S V1", ...]}],
//  "transitions": [{"name", "from": [...], "to": [...], "when": "PBS AND LS2"}]}.
// An error when the source is not an SFC chart that compiles.
Result<nlohmann::json> chart_json(std::string_view source);

}  // namespace rtplc::web
