// Lexer for the control algorithm file (spec fbd-language.md, "The control
// algorithm file"). Structure follows chibicc's tokenize.c: one loop, one branch
// per token class, positions tracked as we go.
#include "lang/lexer.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <string>

namespace rtplc::lang {

const char* tok_name(Tok t) {
  switch (t) {
    case Tok::kEof: return "end of file";
    case Tok::kIdent: return "name";
    case Tok::kRef: return "block id";
    case Tok::kDevice: return "device address";
    case Tok::kNumber: return "number";
    case Tok::kString: return "string";
    case Tok::kMacro: return "MACRO";
    case Tok::kEnd: return "END";
    case Tok::kReturn: return "RETURN";
    case Tok::kSections: return "'%%'";
    case Tok::kLParen: return "'('";
    case Tok::kRParen: return "')'";
    case Tok::kComma: return "','";
    case Tok::kEquals: return "'='";
    case Tok::kColon: return "':'";
    case Tok::kBar: return "'|'";
    case Tok::kLBrace: return "'{'";
    case Tok::kRBrace: return "'}'";
    case Tok::kMinus: return "'-'";
    case Tok::kPlus: return "'+'";
  }
  return "?";
}

namespace {

class Lexer {
 public:
  Lexer(std::string_view src, DiagnosticList& d) : src_(src), diags_(d) {}

  std::vector<Token> run() {
    std::vector<Token> out;
    // A UTF-8 byte-order mark from a Windows editor is not an error.
    if (src_.substr(0, 3) == "\xEF\xBB\xBF") i_ = 3;  // not a column the user can see
    for (;;) {
      skip_space_and_comments();
      if (at_end()) break;
      Token t;
      t.pos = here();
      size_t start = i_;
      if (!lex_one(t)) continue;  // error already reported, character skipped
      t.length = static_cast<uint32_t>(i_ - start);
      t.text = src_.substr(start, i_ - start);
      out.push_back(t);
    }
    Token eof;
    eof.kind = Tok::kEof;
    eof.pos = here();
    eof.length = 1;
    out.push_back(eof);
    return out;
  }

 private:
  bool at_end() const { return i_ >= src_.size(); }
  char peek(size_t k = 0) const { return i_ + k < src_.size() ? src_[i_ + k] : '\0'; }
  SourcePos here() const { return {line_, col_}; }

  void advance(size_t n = 1) {
    for (size_t k = 0; k < n && i_ < src_.size(); ++k) {
      if (src_[i_] == '\n') {
        ++line_;
        col_ = 1;
      } else {
        ++col_;
      }
      ++i_;
    }
  }

  void skip_space_and_comments() {
    for (;;) {
      char c = peek();
      if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') {
        advance();
      } else if (c == '/' && peek(1) == '*') {
        SourcePos start = here();
        advance(2);
        while (!at_end() && !(peek() == '*' && peek(1) == '/')) advance();
        if (at_end()) {
          diags_.error(start, "unterminated comment: '/*' has no matching '*/'", 2);
          return;
        }
        advance(2);
      } else if (c == '/' && peek(1) == '/') {
        while (!at_end() && peek() != '\n') advance();
      } else {
        return;
      }
    }
  }

  static bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
  static bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

  bool lex_one(Token& t) {
    char c = peek();
    switch (c) {
      case '(': t.kind = Tok::kLParen; advance(); return true;
      case ')': t.kind = Tok::kRParen; advance(); return true;
      case ',': t.kind = Tok::kComma; advance(); return true;
      case '=': t.kind = Tok::kEquals; advance(); return true;
      case ':': t.kind = Tok::kColon; advance(); return true;
      case '|': t.kind = Tok::kBar; advance(); return true;
      case '{': t.kind = Tok::kLBrace; advance(); return true;
      case '}': t.kind = Tok::kRBrace; advance(); return true;
      case '-': t.kind = Tok::kMinus; advance(); return true;
      case '+': t.kind = Tok::kPlus; advance(); return true;
      case '%':
        if (peek(1) == '%') {
          t.kind = Tok::kSections;
          advance(2);
          return true;
        }
        break;
      case '"': return lex_string(t);
      default: break;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) ||
        (c == '.' && std::isdigit(static_cast<unsigned char>(peek(1))))) {
      return lex_number(t);
    }
    if (ident_start(c)) return lex_word(t);
    SourcePos pos = here();
    unsigned char uc = static_cast<unsigned char>(c);
    std::string shown = uc >= 0x20 && uc < 0x7f ? std::string("'") + c + "'"
                                                : "byte 0x" + hex(uc);
    diags_.error(pos, "unexpected character " + shown);
    // Skip a whole UTF-8 sequence so one typographic quote is one error, not three.
    advance();
    while (!at_end() && (static_cast<unsigned char>(peek()) & 0xC0) == 0x80) advance();
    return false;
  }

  static std::string hex(unsigned char b) {
    const char* d = "0123456789abcdef";
    return std::string{d[b >> 4], d[b & 15]};
  }

  bool lex_string(Token& t) {
    SourcePos start = here();
    advance();  // opening quote
    while (!at_end() && peek() != '"' && peek() != '\n') advance();
    if (peek() != '"') {
      diags_.error(start, "unterminated string: a label must close with '\"' on the same line");
      return false;
    }
    advance();
    t.kind = Tok::kString;
    return true;
  }

  bool lex_number(Token& t) {
    size_t start = i_;
    while (std::isdigit(static_cast<unsigned char>(peek()))) advance();
    if (peek() == '.') {
      advance();
      while (std::isdigit(static_cast<unsigned char>(peek()))) advance();
    }
    if ((peek() == 'e' || peek() == 'E') &&
        (std::isdigit(static_cast<unsigned char>(peek(1))) ||
         ((peek(1) == '-' || peek(1) == '+') && std::isdigit(static_cast<unsigned char>(peek(2)))))) {
      advance(2);
      while (std::isdigit(static_cast<unsigned char>(peek()))) advance();
    }
    std::string_view text = src_.substr(start, i_ - start);
    t.kind = Tok::kNumber;
    // from_chars is locale-independent: "0.5" means one half whatever LC_NUMERIC says.
    std::string s(text);
    auto conv = std::from_chars(text.data(), text.data() + text.size(), t.value);
    if (conv.ec == std::errc::result_out_of_range) t.value = HUGE_VAL;
    if (ident_char(peek())) {
      SourcePos pos = t.pos;
      while (ident_char(peek())) advance();
      diags_.error(pos, "malformed number '" + std::string(src_.substr(start, i_ - start)) + "'",
                   static_cast<uint32_t>(i_ - start));
      return false;
    }
    if (!std::isfinite(t.value)) {
      diags_.error(t.pos, "number " + s + " is too large", static_cast<uint32_t>(text.size()));
      return false;
    }
    return true;
  }

  bool lex_word(Token& t) {
    size_t start = i_;
    while (ident_char(peek())) advance();
    std::string_view w = src_.substr(start, i_ - start);
    if (w == "MACRO") {
      t.kind = Tok::kMacro;
    } else if (w == "END") {
      t.kind = Tok::kEnd;
    } else if (w == "RETURN" || w == "RETRUN") {
      t.kind = Tok::kReturn;
    } else if (w.size() >= 2 && all_digits(w.substr(1)) && is_ref_letter(w[0])) {
      t.kind = Tok::kRef;
      t.letter = w[0];
      t.number_overflow = !parse_u32(w.substr(1), t.number);
    } else if (w.size() >= 2 && all_digits(w.substr(1)) && (w[0] == 'p' || w[0] == 'd' || w[0] == 'c')) {
      t.kind = Tok::kDevice;
      t.letter = w[0];
      t.number_overflow = !parse_u32(w.substr(1), t.number);
    } else {
      t.kind = Tok::kIdent;
    }
    return true;
  }

  static bool is_ref_letter(char c) {
    return c == 'F' || c == 'D' || c == 'M' || c == 'N' || c == 'P';
  }
  static bool all_digits(std::string_view s) {
    if (s.empty()) return false;
    for (char c : s) {
      if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    }
    return true;
  }
  static bool parse_u32(std::string_view s, uint32_t& out) {
    auto r = std::from_chars(s.data(), s.data() + s.size(), out);
    return r.ec == std::errc{} && r.ptr == s.data() + s.size();
  }

  std::string_view src_;
  DiagnosticList& diags_;
  size_t i_ = 0;
  uint32_t line_ = 1;
  uint32_t col_ = 1;
};

}  // namespace

std::vector<Token> tokenize(std::string_view source, DiagnosticList& diags) {
  return Lexer(source, diags).run();
}

}  // namespace rtplc::lang
