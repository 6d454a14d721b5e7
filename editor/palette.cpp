// The editor's palette: every primitive block of the registry as JSON
// (GET /api/blocks, `rtplc blocks --json`), so the page draws pins, edits
// parameters within their ranges and shows each block's help from the one
// source the compiler reads.
#include <cmath>

#include "blocks/registry.h"
#include "editor/diagram.h"

namespace rtplc::editor {
namespace {

const char* signature_name(Signature s) {
  switch (s) {
    case Signature::kCompute:
      return "compute";
    case Signature::kDeviceIn:
      return "device_in";
    case Signature::kSetpoint:
      return "setpoint";
    case Signature::kDeviceOut:
      return "device_out";
  }
  return "compute";
}

nlohmann::json bound(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

nlohmann::json registry_json() {
  nlohmann::json out = nlohmann::json::array();
  for (const BlockSpec& b : all_blocks()) {
    nlohmann::json inputs = nlohmann::json::array();
    for (uint8_t k = 0; k < b.max_inputs; ++k) {
      inputs.push_back({{"name", b.input_names[k]}, {"kind", kind_name(b.input_kind[k])}, {"optional", k >= b.min_inputs}});
    }
    nlohmann::json params = nlohmann::json::array();
    for (uint8_t k = 0; k < b.param_count; ++k) {
      const ParamSpec& p = b.params[k];
      params.push_back({{"name", p.name},
                        {"meaning", p.meaning},
                        {"default", bound(p.default_value)},
                        {"optional", p.optional},
                        {"min", bound(p.min)},
                        {"max", bound(p.max)},
                        {"min_exclusive", p.min_exclusive},
                        {"integer", p.integer}});
    }
    out.push_back({{"name", b.name},
                   {"alias", b.alias ? nlohmann::json(b.alias) : nlohmann::json(nullptr)},
                   {"group", group_name(b.group)},
                   {"io", io_group_name(b.io)},
                   {"signature", signature_name(b.signature)},
                   {"has_output", b.has_output},
                   {"out_kind", kind_name(b.out_kind)},
                   {"inputs", inputs},
                   {"params", params},
                   {"reads_quality", b.reads_quality},
                   {"state", b.state},
                   {"summary", b.summary},
                   {"contract", b.contract},
                   {"errors", b.errors}});
  }
  return out;
}

}  // namespace rtplc::editor
