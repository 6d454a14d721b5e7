// The lexer: token classes, positions, comments, and errors that keep going.
#include <gtest/gtest.h>

#include "lang/lexer.h"

namespace rtplc::lang {
namespace {

std::vector<Token> lex(std::string_view s, DiagnosticList* d = nullptr) {
  DiagnosticList local;
  return tokenize(s, d ? *d : local);
}

TEST(Lexer, classifies_ids_devices_numbers_strings_and_keywords) {
  auto t = lex("F12 = dai(p0, d1, c23, \"PV_1\") D4 M5 N6 P7 MACRO END RETURN %% 0.5 1e-3 |:{}-+");
  std::vector<Tok> kinds;
  for (auto& k : t) kinds.push_back(k.kind);
  EXPECT_EQ(kinds, (std::vector<Tok>{Tok::kRef, Tok::kEquals, Tok::kIdent, Tok::kLParen,
                                     Tok::kDevice, Tok::kComma, Tok::kDevice, Tok::kComma,
                                     Tok::kDevice, Tok::kComma, Tok::kString, Tok::kRParen,
                                     Tok::kRef, Tok::kRef, Tok::kRef, Tok::kRef, Tok::kMacro,
                                     Tok::kEnd, Tok::kReturn, Tok::kSections, Tok::kNumber,
                                     Tok::kNumber, Tok::kBar, Tok::kColon, Tok::kLBrace,
                                     Tok::kRBrace, Tok::kMinus, Tok::kPlus, Tok::kEof}));
  EXPECT_EQ(t[0].letter, 'F');
  EXPECT_EQ(t[0].number, 12u);
  EXPECT_EQ(t[8].letter, 'c');
  EXPECT_EQ(t[8].number, 23u);
  EXPECT_DOUBLE_EQ(t[20].value, 0.5);
  EXPECT_DOUBLE_EQ(t[21].value, 1e-3);
}

TEST(Lexer, tracks_line_and_column) {
  auto t = lex("%%\n  F1 = add(F2,\tF3)\n");
  EXPECT_EQ(t[1].pos.line, 2u);
  EXPECT_EQ(t[1].pos.col, 3u);
  EXPECT_EQ(t[7].text, "F3");
  EXPECT_EQ(t[7].pos.col, 16u);
}

TEST(Lexer, skips_both_comment_styles) {
  auto t = lex("/* a\n multi-line */ F1 // to the end\nF2");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].text, "F1");
  EXPECT_EQ(t[1].text, "F2");
  EXPECT_EQ(t[1].pos.line, 3u);
}

TEST(Lexer, accepts_the_seeds_RETRUN_spelling_and_a_byte_order_mark) {
  auto t = lex("\xEF\xBB\xBFRETRUN(M1)");
  EXPECT_EQ(t[0].kind, Tok::kReturn);
  EXPECT_EQ(t[0].pos.col, 1u);
}

TEST(Lexer, reports_errors_with_positions_and_continues) {
  DiagnosticList d;
  auto t = lex("F1 = add(F2 # F3)\n\"open\nF4 /* never closed", &d);
  EXPECT_EQ(d.error_count(), 3u);
  ASSERT_GE(d.items().size(), 3u);
  EXPECT_EQ(d.items()[0].pos.line, 1u);
  EXPECT_EQ(d.items()[0].pos.col, 13u);
  EXPECT_NE(d.items()[1].message.find("unterminated string"), std::string::npos);
  EXPECT_NE(d.items()[2].message.find("unterminated comment"), std::string::npos);
  // The tokens after the bad character are still there.
  bool saw_f3 = false, saw_f4 = false;
  for (auto& k : t) {
    saw_f3 |= k.text == "F3";
    saw_f4 |= k.text == "F4";
  }
  EXPECT_TRUE(saw_f3);
  EXPECT_TRUE(saw_f4);
}

TEST(Lexer, rejects_malformed_and_huge_numbers) {
  DiagnosticList d;
  lex("1.5x 1e999", &d);
  EXPECT_EQ(d.error_count(), 2u);
  EXPECT_NE(d.items()[0].message.find("malformed number"), std::string::npos);
  EXPECT_NE(d.items()[1].message.find("too large"), std::string::npos);
}

TEST(Lexer, one_error_for_a_multibyte_character) {
  DiagnosticList d;
  lex("F1 = asp(d0, c0, 1, \xE2\x80\x9Clabel\xE2\x80\x9D)", &d);  // typographic quotes
  EXPECT_EQ(d.error_count(), 2u);
}

}  // namespace
}  // namespace rtplc::lang
