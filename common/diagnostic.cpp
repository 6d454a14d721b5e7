// Rendering of compiler-style diagnostics (see diagnostic.h).
#include "common/diagnostic.h"

#include <algorithm>
#include <string>

namespace rtplc {

void DiagnosticList::add(Severity s, SourcePos pos, std::string msg, uint32_t length) {
  // The same message at the same place is said once (a macro expanded many times
  // would otherwise repeat its definition's problems at every call).
  for (const Diagnostic& d : items_) {
    if (d.severity == s && d.pos.line == pos.line && d.pos.col == pos.col && d.message == msg) {
      return;
    }
  }
  if (s == Severity::kError) ++errors_;
  if (s == Severity::kWarning) ++warnings_;
  if (items_.size() >= kMaxRecorded) {
    ++dropped_;
    return;
  }
  items_.push_back(Diagnostic{s, pos, length == 0 ? 1 : length, std::move(msg)});
}

void DiagnosticList::error(SourcePos pos, std::string msg, uint32_t length) {
  add(Severity::kError, pos, std::move(msg), length);
}
void DiagnosticList::warning(SourcePos pos, std::string msg, uint32_t length) {
  add(Severity::kWarning, pos, std::move(msg), length);
}
void DiagnosticList::note(SourcePos pos, std::string msg, uint32_t length) {
  add(Severity::kNote, pos, std::move(msg), length);
}

std::string_view source_line(std::string_view source, uint32_t line) {
  if (line == 0) return {};
  size_t start = 0;
  for (uint32_t l = 1; l < line; ++l) {
    size_t nl = source.find('\n', start);
    if (nl == std::string_view::npos) return {};
    start = nl + 1;
  }
  size_t end = source.find('\n', start);
  if (end == std::string_view::npos) end = source.size();
  std::string_view s = source.substr(start, end - start);
  if (!s.empty() && s.back() == '\r') s.remove_suffix(1);
  return s;
}

namespace {

// Length of the valid UTF-8 sequence starting at s[i] (a printable character
// beyond ASCII), or 0 when the bytes there are not one.
size_t utf8_length(std::string_view s, size_t i) {
  const auto b = static_cast<unsigned char>(s[i]);
  size_t n = 0;
  if (b >= 0xC2 && b <= 0xDF) n = 2;
  else if (b >= 0xE0 && b <= 0xEF) n = 3;
  else if (b >= 0xF0 && b <= 0xF4) n = 4;
  else return 0;
  if (i + n > s.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) return 0;
  }
  return n;
}

// Counts the terminal columns of escaped text: one per character, a tab as is.
std::string blank_like(std::string_view escaped) {
  std::string out;
  for (char c : escaped) {
    if (c == '\t') out += '\t';
    else if ((static_cast<unsigned char>(c) & 0xC0) != 0x80) out += ' ';
  }
  return out;
}

size_t columns_of(std::string_view escaped) {
  size_t n = 0;
  for (char c : escaped) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80 ? 1 : 0;
  return n;
}

}  // namespace

std::string escape_for_terminal(std::string_view text, bool keep_newlines) {
  static const char* const kHex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    const auto b = static_cast<unsigned char>(text[i]);
    if ((b >= 0x20 && b < 0x7F) || b == '\t' || (b == '\n' && keep_newlines)) {
      out += static_cast<char>(b);
    } else if (const size_t n = b >= 0x80 ? utf8_length(text, i) : 0; n > 0) {
      out.append(text.substr(i, n));
      i += n - 1;
    } else {
      out += "\\x";
      out += kHex[b >> 4];
      out += kHex[b & 0xF];
    }
  }
  return out;
}

std::string DiagnosticList::render(std::string_view file_name, std::string_view source,
                                   bool color) const {
  const char* bold = color ? "\x1b[1m" : "";
  const char* red = color ? "\x1b[1;31m" : "";
  const char* magenta = color ? "\x1b[1;35m" : "";
  const char* cyan = color ? "\x1b[1;36m" : "";
  const char* green = color ? "\x1b[1;32m" : "";
  const char* reset = color ? "\x1b[0m" : "";
  // Errors and warnings in source order, each followed by its notes; items
  // without a position (whole-file remarks) last.
  std::vector<std::vector<const Diagnostic*>> groups;
  for (const Diagnostic& d : items_) {
    if (d.severity == Severity::kNote && !groups.empty() && d.pos.line != 0) {
      groups.back().push_back(&d);
    } else {
      groups.push_back({&d});
    }
  }
  std::stable_sort(groups.begin(), groups.end(), [](const auto& a, const auto& b) {
    const SourcePos pa = a.front()->pos, pb = b.front()->pos;
    const uint64_t ka = pa.line == 0 ? UINT64_MAX : (uint64_t{pa.line} << 32 | pa.col);
    const uint64_t kb = pb.line == 0 ? UINT64_MAX : (uint64_t{pb.line} << 32 | pb.col);
    return ka < kb;
  });
  std::vector<const Diagnostic*> ordered;
  for (const auto& g : groups) ordered.insert(ordered.end(), g.begin(), g.end());
  std::string out;
  for (const Diagnostic* dp : ordered) {
    const Diagnostic& d = *dp;
    const char* kind = d.severity == Severity::kError     ? "error"
                       : d.severity == Severity::kWarning ? "warning"
                                                          : "note";
    const char* kc = d.severity == Severity::kError     ? red
                     : d.severity == Severity::kWarning ? magenta
                                                        : cyan;
    out += bold;
    out += escape_for_terminal(file_name);
    if (d.pos.line > 0) {
      out += ':' + std::to_string(d.pos.line) + ':' + std::to_string(d.pos.col);
    }
    out += ": ";
    out += reset;
    out += kc;
    out += kind;
    out += ": ";
    out += reset;
    out += bold;
    out += escape_for_terminal(d.message, true);
    out += reset;
    out += '\n';
    std::string_view text = source_line(source, d.pos.line);
    if (d.pos.line > 0 && d.pos.col > 0) {
      std::string ln = std::to_string(d.pos.line);
      out += ' ' + ln + " | ";
      // Control bytes and broken UTF-8 are shown escaped (a binary file must not
      // drive the terminal, and a NUL must not end the output); tabs are kept so
      // the caret lines up with what the user's editor shows. Columns count
      // bytes of the source, so the caret is placed under the escaped text.
      out += escape_for_terminal(text);
      out += '\n';
      out += ' ' + std::string(ln.size(), ' ') + " | ";
      const size_t col = std::min<size_t>(d.pos.col - 1, text.size());
      out += blank_like(escape_for_terminal(text.substr(0, col)));
      out += green;
      out += '^';
      size_t width = std::max<size_t>(1, d.length);
      if (col + width > text.size() && text.size() > col) width = text.size() - col;
      width = std::max<size_t>(1, columns_of(escape_for_terminal(text.substr(col, width))));
      for (size_t i = 1; i < width; ++i) out += '~';
      out += reset;
      out += '\n';
    }
  }
  if (dropped_ > 0) {
    out += std::to_string(dropped_) + " more diagnostic" + (dropped_ == 1 ? "" : "s") +
           " not shown (only the first " + std::to_string(kMaxRecorded) + " are kept)\n";
  }
  return out;
}

size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

}  // namespace rtplc
