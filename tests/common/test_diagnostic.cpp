// Rendering of diagnostics against hostile sources: binary bytes, NUL, escape
// sequences, broken UTF-8, and more diagnostics than are kept.
#include "common/diagnostic.h"

#include <gtest/gtest.h>

#include <string>

namespace rtplc {
namespace {

// True when `s` holds no byte a terminal would act on (newline and tab aside).
bool printable(const std::string& s) {
  for (char c : s) {
    const auto b = static_cast<unsigned char>(c);
    if ((b < 0x20 && b != '\n' && b != '\t') || b == 0x7F) return false;
  }
  return true;
}

TEST(Diagnostic, escapes_control_bytes_and_nul_in_the_source_line) {
  const std::string src = std::string("x = \x1b[2Jab\0cd\x7f", 15) + "\n";
  DiagnosticList d;
  d.error(SourcePos{1, 9}, "bad thing");
  const std::string out = d.render("f.fbd", src);
  EXPECT_TRUE(printable(out)) << out;
  EXPECT_NE(out.find("x = \\x1b[2Jab\\x00cd\\x7f"), std::string::npos) << out;
  EXPECT_EQ(out.back(), '\n');
}

TEST(Diagnostic, caret_sits_under_the_escaped_column) {
  // Column 6 is 'Z', after one control byte shown as four characters.
  const std::string src = "ab\x01" "cdZ\n";
  DiagnosticList d;
  d.error(SourcePos{1, 6}, "here");
  const std::string out = d.render("f", src);
  const size_t line = out.find(" 1 | ");
  ASSERT_NE(line, std::string::npos) << out;
  const size_t z = out.find('Z', line) - line;
  const size_t caret = out.find('^', line) - out.find('\n', line) - 1;
  EXPECT_EQ(z, caret) << out;
}

TEST(Diagnostic, keeps_valid_utf8_and_escapes_broken_utf8) {
  EXPECT_EQ(escape_for_terminal("Temp \xc2\xb0" "C"), "Temp \xc2\xb0" "C");
  EXPECT_EQ(escape_for_terminal("a\xc3(b"), "a\\xc3(b");
  EXPECT_EQ(escape_for_terminal("tab\there"), "tab\there");
  EXPECT_EQ(escape_for_terminal("two\nlines"), "two\\x0alines");
  EXPECT_EQ(escape_for_terminal("two\nlines", true), "two\nlines");
}

TEST(Diagnostic, escapes_bytes_in_messages_and_file_names) {
  DiagnosticList d;
  d.error(SourcePos{}, std::string("unknown token '\x1b]0;pwned\x07'"));
  const std::string out = d.render(std::string("evil\x1b.fbd"), "");
  EXPECT_TRUE(printable(out)) << out;
  EXPECT_NE(out.find("evil\\x1b.fbd"), std::string::npos) << out;
}

TEST(Diagnostic, says_how_many_were_left_out_so_the_count_adds_up) {
  DiagnosticList d;
  const size_t total = DiagnosticList::kMaxRecorded + 37;
  for (uint32_t i = 1; i <= total; ++i) d.error(SourcePos{i, 1}, "error " + std::to_string(i));
  d.warning(SourcePos{1, 1}, "and a warning");
  EXPECT_EQ(d.error_count(), total);
  EXPECT_EQ(d.dropped_count(), 38u);
  const std::string out = d.render("f", "");
  size_t shown = 0;
  for (size_t p = out.find(": error: "); p != std::string::npos; p = out.find(": error: ", p + 1)) ++shown;
  EXPECT_EQ(shown, DiagnosticList::kMaxRecorded);
  EXPECT_NE(out.find("38 more diagnostics not shown"), std::string::npos) << out.substr(out.size() - 200);
}

TEST(Diagnostic, nothing_left_out_says_nothing) {
  DiagnosticList d;
  d.error(SourcePos{1, 1}, "one");
  d.warning(SourcePos{2, 1}, "two");
  EXPECT_EQ(d.render("f", "a\nb\n").find("not shown"), std::string::npos);
}

}  // namespace
}  // namespace rtplc
