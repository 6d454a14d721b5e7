// The plan file of `rtplc fieldbus plan` (docs/fieldbus.md, "The plan file";
// spec io-links.md, "Fieldbus bandwidth allocation"): YAML -> Design. Keys are
// checked against this file's own schema rows through config/'s YamlReader, so
// a malformed plan gets the same file:line:col errors with a caret, "did you
// mean" hints and duplicate-key notes as the runtime configuration.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "common/diagnostic.h"
#include "fieldbus/design.h"

namespace rtplc::fieldbus {

struct PlanFile {
  std::string file;
  std::string source;
  DiagnosticList diags;
  std::optional<Design> design;  // set when there is no error

  std::string render(bool color = false) const { return diags.render(file, source, color); }
};

// `file_name` only names the text in messages.
PlanFile parse_plan_file(std::string_view yaml, const std::string& file_name);
PlanFile load_plan_file(const std::string& path);

}  // namespace rtplc::fieldbus
