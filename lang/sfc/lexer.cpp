// Lexer for SFC programs (docs/sfc.md, "File layout"): one loop, one branch per
// token class, positions tracked as we go (the FBD lexer's shape).
#include "lang/sfc/lexer.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <string>

namespace rtplc::lang::sfc {

const char* tok_name(Tok t) {
  switch (t) {
    case Tok::kEof:
      return "end of file";
    case Tok::kName:
      return "name";
    case Tok::kNumber:
      return "number";
    case Tok::kString:
      return "string";
    case Tok::kLParen:
      return "'('";
    case Tok::kRParen:
      return "')'";
    case Tok::kComma:
      return "','";
    case Tok::kEquals:
      return "'='";
    case Tok::kColon:
      return "':'";
    case Tok::kStar:
      return "'*'";
    case Tok::kArrow:
      return "'->'";
  }
  return "?";
}

namespace {

bool is_name_start(char c) {
  return std::isalpha(static_cast<unsigned char>(c)) || c == '_';
}
bool is_name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}
bool is_digit(char c) {
  return std::isdigit(static_cast<unsigned char>(c)) != 0;
}

class Lexer {
 public:
  Lexer(std::string_view src, DiagnosticList* d) : src_(src), diags_(d) {
    if (src_.substr(0, 3) == "\xEF\xBB\xBF")
      i_ = line_start_ = 3;  // a byte-order mark is not an error
  }

  // Skips blanks and both comment forms; false at the end of the text.
  bool skip_space_and_comments() {
    for (;;) {
      if (at_end()) return false;
      const char c = src_[i_];
      if (c == '\n') {
        ++line_;
        line_start_ = ++i_;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
        ++i_;
      } else if (c == '/' && peek(1) == '/') {
        while (!at_end() && src_[i_] != '\n') ++i_;
      } else if (c == '/' && peek(1) == '*') {
        const SourcePos start = here();
        i_ += 2;
        while (!at_end() && !(src_[i_] == '*' && peek(1) == '/')) {
          if (src_[i_] == '\n') {
            ++line_;
            line_start_ = i_ + 1;
          }
          ++i_;
        }
        if (at_end()) {
          report(start, "comment opened here is never closed (expected '*/')");
          return false;
        }
        i_ += 2;
      } else {
        return true;
      }
    }
  }

  std::vector<Token> run() {
    std::vector<Token> out;
    while (skip_space_and_comments()) {
      Token t;
      t.pos = here();
      const size_t start = i_;
      if (!lex_one(t)) continue;
      t.length = static_cast<uint32_t>(i_ - start);
      if (t.kind != Tok::kString) t.text = src_.substr(start, i_ - start);
      out.push_back(t);
    }
    Token eof;
    eof.pos = here();
    out.push_back(eof);
    return out;
  }

  // The first name of the text, or "" when it starts with something else.
  std::string_view first_name() {
    if (!skip_space_and_comments() || !is_name_start(src_[i_])) return {};
    const size_t start = i_;
    while (!at_end() && is_name_char(src_[i_])) ++i_;
    return src_.substr(start, i_ - start);
  }

 private:
  bool lex_one(Token& t) {
    const char c = src_[i_];
    if ((c == 'T' || c == 't') && peek(1) == '#') {  // IEC duration T#5s
      i_ += 2;
      if (!is_digit(cur())) {
        report(t.pos, "expected a duration after 'T#', such as T#5s or T#200ms");
        return false;
      }
      return lex_number(t, true);
    }
    if (is_name_start(c)) {
      // Names may hold dots between parts (Fill.X): the step-active flag.
      while (!at_end() && (is_name_char(src_[i_]) || (src_[i_] == '.' && i_ + 1 < src_.size() &&
                                                      is_name_start(src_[i_ + 1])))) {
        ++i_;
      }
      t.kind = Tok::kName;
      return true;
    }
    if (is_digit(c) || (c == '.' && is_digit(peek(1))) ||
        (c == '-' && (is_digit(peek(1)) || (peek(1) == '.' && is_digit(peek(2)))))) {
      return lex_number(t, false);
    }
    if (c == '"') return lex_string(t);
    ++i_;
    switch (c) {
      case '(':
        t.kind = Tok::kLParen;
        return true;
      case ')':
        t.kind = Tok::kRParen;
        return true;
      case ',':
        t.kind = Tok::kComma;
        return true;
      case '=':
        t.kind = Tok::kEquals;
        return true;
      case ':':
        t.kind = Tok::kColon;
        return true;
      case '*':
        t.kind = Tok::kStar;
        return true;
      case '-':
        if (cur() == '>') {
          ++i_;
          t.kind = Tok::kArrow;
          return true;
        }
        break;
      default:
        break;
    }
    const unsigned char u = static_cast<unsigned char>(c);
    if (u >= 0x80) {
      while (!at_end() && (static_cast<unsigned char>(src_[i_]) & 0xC0) == 0x80) ++i_;
      report(t.pos, "unexpected non-ASCII character (names are letters, digits and '_')");
    } else if (std::isprint(u)) {
      report(t.pos, std::string("unexpected character '") + c + "'");
    } else {
      report(t.pos, "unexpected control character " + std::to_string(u));
    }
    return false;
  }

  bool lex_number(Token& t, bool need_unit) {
    const size_t start = i_;
    if (cur() == '-') ++i_;
    while (is_digit(cur())) ++i_;
    if (cur() == '.') {
      ++i_;
      while (is_digit(cur())) ++i_;
    }
    if ((cur() == 'e' || cur() == 'E') &&
        (is_digit(peek(1)) || ((peek(1) == '-' || peek(1) == '+') && is_digit(peek(2))))) {
      i_ += 2;
      while (is_digit(cur())) ++i_;
    }
    const std::string text(src_.substr(start, i_ - start));
    double v = std::strtod(text.c_str(), nullptr);
    const size_t unit_start = i_;
    while (is_name_char(cur())) ++i_;
    const std::string_view unit = src_.substr(unit_start, i_ - unit_start);
    t.kind = Tok::kNumber;
    if (!unit.empty()) {
      t.has_unit = true;
      if (unit == "s") {
      } else if (unit == "ms") {
        v /= 1000.0;
      } else if (unit == "min") {
        v *= 60.0;
      } else {
        report(t.pos, "unknown time unit '" + std::string(unit) + "' (use s, ms or min)");
        return false;
      }
    } else if (need_unit) {
      report(t.pos, "a T# duration needs a unit: s, ms or min");
      return false;
    }
    if (!std::isfinite(v)) {
      report(t.pos, "number out of range");
      return false;
    }
    t.value = v;
    return true;
  }

  bool lex_string(Token& t) {
    ++i_;
    const size_t start = i_;
    while (!at_end() && src_[i_] != '"' && src_[i_] != '\n') ++i_;
    if (at_end() || src_[i_] != '"') {
      report(t.pos, "string is not closed on this line (expected '\"')");
      return false;
    }
    t.kind = Tok::kString;
    t.text = src_.substr(start, i_ - start);
    ++i_;
    return true;
  }

  void report(SourcePos p, std::string msg) {
    if (diags_) diags_->error(p, std::move(msg));
  }
  bool at_end() const { return i_ >= src_.size(); }
  char cur() const { return at_end() ? '\0' : src_[i_]; }
  char peek(size_t k) const { return i_ + k < src_.size() ? src_[i_ + k] : '\0'; }
  SourcePos here() const { return SourcePos{line_, static_cast<uint32_t>(i_ - line_start_ + 1)}; }

  std::string_view src_;
  DiagnosticList* diags_;
  size_t i_ = 0;
  uint32_t line_ = 1;
  size_t line_start_ = 0;
};

}  // namespace

std::vector<Token> tokenize(std::string_view source, DiagnosticList& diags) {
  return Lexer(source, &diags).run();
}

bool starts_with_sfc_keyword(std::string_view source) {
  return Lexer(source, nullptr).first_name() == "SFC";
}

}  // namespace rtplc::lang::sfc
