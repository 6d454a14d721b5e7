// Table and JSON renderings of the doctor's report (spec: runtime.md, "The command line").
#include "kernel_rt/doctor_render.h"

#include <fmt/format.h>

#include <vector>

namespace rtplc::kernel_rt {
namespace {

constexpr size_t kTitleWidth = 24;
constexpr size_t kVerdictWidth = 6;

// Greedy word wrap; a word longer than the width gets a line of its own.
std::vector<std::string> wrap(std::string_view text, size_t width) {
  std::vector<std::string> lines;
  std::string line;
  size_t pos = 0;
  while (pos < text.size()) {
    while (pos < text.size() && text[pos] == ' ') ++pos;
    size_t end = text.find(' ', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view word = text.substr(pos, end - pos);
    if (!word.empty()) {
      if (!line.empty() && line.size() + 1 + word.size() > width) {
        lines.push_back(std::move(line));
        line.clear();
      }
      if (!line.empty()) line += ' ';
      line += word;
    }
    pos = end;
  }
  if (!line.empty()) lines.push_back(std::move(line));
  if (lines.empty()) lines.emplace_back();
  return lines;
}

const char* color_of(Verdict v) {
  switch (v) {
    case Verdict::kOk:
      return "\x1b[32m";
    case Verdict::kWarn:
      return "\x1b[33m";
    case Verdict::kFail:
      return "\x1b[1;31m";
  }
  return "";
}

const char* lower_name(Verdict v) {
  switch (v) {
    case Verdict::kOk:
      return "ok";
    case Verdict::kWarn:
      return "warn";
    case Verdict::kFail:
      return "fail";
  }
  return "?";
}

}  // namespace

std::string render_doctor_table(const DoctorReport& report, const TableStyle& style) {
  const size_t indent = kVerdictWidth + kTitleWidth + 2;
  const size_t text_width = style.width > indent + 30 ? style.width - indent : 30;
  const std::string pad(indent, ' ');
  std::string out;
  out += report.kernel.realtime
             ? fmt::format("rtplc doctor: kernel {} is PREEMPT_RT\n\n", report.kernel.release)
             : fmt::format("rtplc doctor: kernel {} is NOT PREEMPT_RT\n\n", report.kernel.release);
  out += fmt::format("{:<{}}{:<{}}  {}\n", "", kVerdictWidth, "CHECK", kTitleWidth, "FOUND / FIX");
  for (const auto& c : report.checks) {
    const std::string verdict = verdict_name(c.verdict);
    const std::string shown =
        style.color ? fmt::format("{}{:<{}}\x1b[0m", color_of(c.verdict), verdict, kVerdictWidth)
                    : fmt::format("{:<{}}", verdict, kVerdictWidth);
    const auto found = wrap(c.found, text_width);
    out += fmt::format("{}{:<{}}  {}\n", shown, c.title, kTitleWidth, found.front());
    for (size_t i = 1; i < found.size(); ++i) out += pad + found[i] + "\n";
    if (!c.fix.empty()) {
      const auto fix = wrap("fix: " + c.fix, text_width - 2);
      for (size_t i = 0; i < fix.size(); ++i) out += pad + (i == 0 ? "" : "  ") + fix[i] + "\n";
    }
  }
  const size_t fails = report.count(Verdict::kFail);
  const size_t warns = report.count(Verdict::kWarn);
  const size_t oks = report.count(Verdict::kOk);
  out += "\n";
  if (report.ready()) {
    out += warns == 0
               ? fmt::format("READY for real time: all {} checks OK.\n", oks)
               : fmt::format("READY for real time, with {} warning(s) that cost latency ({} OK).\n",
                             warns, oks);
  } else {
    out +=
        fmt::format("NOT READY for real time: {} FAIL, {} WARN, {} OK. Fix the FAIL lines first.\n",
                    fails, warns, oks);
  }
  return out;
}

std::string json_quote(std::string_view s) {
  std::string out = "\"";
  for (char ch : s) {
    const auto u = static_cast<unsigned char>(ch);
    switch (ch) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (u < 0x20) {
          out += fmt::format("\\u{:04x}", static_cast<unsigned>(u));
        } else {
          out += ch;
        }
    }
  }
  out += '"';
  return out;
}

std::string render_doctor_json(const DoctorReport& report) {
  const auto& k = report.kernel;
  std::string out = "{\n";
  out += fmt::format("  \"ready\": {},\n", report.ready() ? "true" : "false");
  out += fmt::format(
      "  \"kernel\": {{\"realtime\": {}, \"release\": {}, \"version\": {}, \"preemption\": {}, "
      "\"dynamic\": {}, \"evidence\": [",
      k.realtime ? "true" : "false", json_quote(k.release), json_quote(k.version),
      json_quote(preempt_model_name(k.model)), k.dynamic ? "true" : "false");
  for (size_t i = 0; i < k.evidence.size(); ++i) out += (i ? ", " : "") + json_quote(k.evidence[i]);
  out += "]},\n";
  out += fmt::format("  \"summary\": {{\"ok\": {}, \"warn\": {}, \"fail\": {}}},\n",
                     report.count(Verdict::kOk), report.count(Verdict::kWarn),
                     report.count(Verdict::kFail));
  out += "  \"checks\": [\n";
  for (size_t i = 0; i < report.checks.size(); ++i) {
    const auto& c = report.checks[i];
    out += fmt::format(
        "    {{\"id\": {}, \"title\": {}, \"verdict\": \"{}\", \"found\": {}, \"fix\": {}}}{}\n",
        json_quote(c.id), json_quote(c.title), lower_name(c.verdict), json_quote(c.found),
        json_quote(c.fix), i + 1 < report.checks.size() ? "," : "");
  }
  out += "  ]\n}\n";
  return out;
}

}  // namespace rtplc::kernel_rt
