// What the config tests share: parsing text without touching the disk, and
// finding a diagnostic by position and message.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "config/config.h"

namespace rtplc::config::testing {

inline LoadResult parse(std::string_view yaml, const std::string& base_dir = "/plant") {
  LoadOptions o;
  o.check_program_files = false;
  return parse_config(yaml, "t.yaml", base_dir, o);
}

// True when `r` holds a diagnostic of `severity` at line:col whose message
// contains `text`; on failure the test output shows every diagnostic.
inline ::testing::AssertionResult has_diag(const LoadResult& r, uint32_t line, uint32_t col,
                                           std::string_view text,
                                           Severity severity = Severity::kError) {
  for (const Diagnostic& d : r.diags.items()) {
    if (d.severity == severity && d.pos.line == line && d.pos.col == col &&
        d.message.find(text) != std::string::npos) {
      return ::testing::AssertionSuccess();
    }
  }
  return ::testing::AssertionFailure()
         << "no diagnostic at " << line << ":" << col << " containing '" << text << "'; got:\n"
         << r.render();
}

}  // namespace rtplc::config::testing
