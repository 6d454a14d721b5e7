// The ST tests' view of a refusal: the first error of a source as
// "line:col: message", or "compiled" when there is none.
#pragma once

#include <string>

#include "lang/compiler.h"
#include "lang/front_end.h"

namespace rtplc::testing {

inline std::string first_error(const std::string& src) {
  const lang::CompileResult r = lang::compile_source(src);
  if (r.ok() || r.diags.items().empty()) return "compiled";
  const auto& d = r.diags.items()[0];
  return std::to_string(d.pos.line) + ":" + std::to_string(d.pos.col) + ": " + d.message;
}

}  // namespace rtplc::testing
