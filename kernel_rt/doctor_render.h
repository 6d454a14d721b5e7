// Renders a DoctorReport for people (a table with the fixes under each finding) and for
// programs (JSON). Returns text; printing is the caller's business (spec: runtime.md,
// "The command line": `rtplc doctor`).
#pragma once

#include <string>

#include "kernel_rt/doctor.h"

namespace rtplc::kernel_rt {

struct TableStyle {
  size_t width = 100;  // wrap long findings at this column
  bool color = false;  // ANSI colours on the verdicts
};

std::string render_doctor_table(const DoctorReport& report, const TableStyle& style = {});

// {"ready": bool, "kernel": {...}, "summary": {"ok": n, "warn": n, "fail": n},
//  "checks": [{"id", "title", "verdict": "ok|warn|fail", "found", "fix"}]}
std::string render_doctor_json(const DoctorReport& report);

// JSON string literal with the quotes, escaping what RFC 8259 requires.
std::string json_quote(std::string_view s);

}  // namespace rtplc::kernel_rt
