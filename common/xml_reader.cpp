// The XML reader behind the PNML and PLCopen importers (see xml_reader.h).
#include "common/xml_reader.h"

#include "common/text.h"

#include <cstdint>

namespace rtplc {
namespace {

class XmlParser {
 public:
  XmlParser(std::string_view text, DiagnosticList& diags) : s_(text), diags_(diags) {}

  std::optional<XmlElement> document() {
    if (s_.substr(0, 3) == "\xEF\xBB\xBF") advance(3);  // UTF-8 byte order mark
    if (!misc()) return std::nullopt;
    if (at_end() || peek() != '<') return fail("expected the root element");
    XmlElement root;
    if (!element(root, 1)) return std::nullopt;
    if (!misc()) return std::nullopt;
    if (!at_end()) return fail("text after the root element");
    return root;
  }

 private:
  bool at_end() const { return i_ >= s_.size(); }
  char peek(size_t k = 0) const { return i_ + k < s_.size() ? s_[i_ + k] : '\0'; }
  bool starts(std::string_view w) const { return s_.substr(i_, w.size()) == w; }
  void advance(size_t n = 1) {
    for (size_t k = 0; k < n && i_ < s_.size(); ++k, ++i_) {
      if (s_[i_] == '\n') {
        ++line_;
        col_ = 1;
      } else if ((static_cast<unsigned char>(s_[i_]) & 0xC0) != 0x80) {
        ++col_;  // count characters, not UTF-8 continuation bytes
      }
    }
  }
  SourcePos here() const { return SourcePos{line_, col_}; }
  std::nullopt_t fail(const std::string& msg) {
    diags_.error(here(), msg);
    failed_ = true;
    return std::nullopt;
  }
  bool failb(const std::string& msg) {
    fail(msg);
    return false;
  }
  void skip_space() {
    while (!at_end() && (peek() == ' ' || peek() == '\t' || peek() == '\n' || peek() == '\r'))
      advance();
  }
  static bool name_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.' || c == ':' || (static_cast<unsigned char>(c) >= 0x80);
  }
  static bool name_start(char c) {
    return name_char(c) && !(c >= '0' && c <= '9') && c != '-' && c != '.';
  }

  bool name(std::string& out) {
    if (at_end() || !name_start(peek())) return failb("expected a name");
    const size_t b = i_;
    while (!at_end() && name_char(peek())) advance();
    out.assign(s_.substr(b, i_ - b));
    return true;
  }

  // Comments, processing instructions, a DOCTYPE and white space between elements.
  bool misc() {
    for (;;) {
      skip_space();
      if (starts("<!--")) {
        if (!comment()) return false;
      } else if (starts("<?")) {
        if (!skip_until("?>", "processing instruction")) return false;
      } else if (starts("<!DOCTYPE")) {
        if (!doctype()) return false;
      } else {
        return true;
      }
    }
  }
  bool comment() {
    advance(4);
    return skip_until("-->", "comment");
  }
  bool skip_until(std::string_view end, const char* what) {
    const SourcePos start = here();
    const size_t k = s_.find(end, i_);
    if (k == std::string_view::npos) {
      diags_.error(start, std::string("unterminated ") + what);
      failed_ = true;
      return false;
    }
    advance(k + end.size() - i_);
    return true;
  }
  bool doctype() {
    // Skipped whole, internal subset included (brackets balanced, quotes respected).
    const SourcePos start = here();
    int depth = 0;
    char quote = 0;
    while (!at_end()) {
      const char c = peek();
      advance();
      if (quote) {
        if (c == quote) quote = 0;
      } else if (c == '"' || c == '\'') {
        quote = c;
      } else if (c == '[') {
        ++depth;
      } else if (c == ']') {
        --depth;
      } else if (c == '>' && depth <= 0) {
        return true;
      }
    }
    diags_.error(start, "unterminated DOCTYPE");
    failed_ = true;
    return false;
  }

  // Appends the character reference or entity at '&' to out.
  bool reference(std::string& out) {
    const SourcePos start = here();
    const size_t semi = s_.find(';', i_);
    if (semi == std::string_view::npos || semi - i_ > 12)
      return failb("'&' does not start a reference (write &amp;)");
    const std::string_view ref = s_.substr(i_ + 1, semi - i_ - 1);
    uint32_t cp = 0;
    if (ref == "lt")
      cp = '<';
    else if (ref == "gt")
      cp = '>';
    else if (ref == "amp")
      cp = '&';
    else if (ref == "quot")
      cp = '"';
    else if (ref == "apos")
      cp = '\'';
    else if (ref.size() >= 2 && ref[0] == '#') {
      const bool hex = ref[1] == 'x';
      const std::string_view digits = ref.substr(hex ? 2 : 1);
      if (digits.empty()) return failb("empty character reference");
      for (char c : digits) {
        uint32_t d = 0;
        if (c >= '0' && c <= '9')
          d = static_cast<uint32_t>(c - '0');
        else if (hex && c >= 'a' && c <= 'f')
          d = static_cast<uint32_t>(c - 'a' + 10);
        else if (hex && c >= 'A' && c <= 'F')
          d = static_cast<uint32_t>(c - 'A' + 10);
        else
          return failb("bad digit in character reference");
        cp = cp * (hex ? 16 : 10) + d;
        if (cp > 0x10FFFF) return failb("character reference out of range");
      }
      if (cp == 0) return failb("character reference to NUL");
    } else {
      diags_.error(start, "unknown entity '&" + std::string(ref) + ";'");
      failed_ = true;
      return false;
    }
    append_utf8(out, static_cast<uint32_t>(cp));
    advance(semi + 1 - i_);
    return true;
  }

  bool attribute_value(std::string& out) {
    const char q = peek();
    if (q != '"' && q != '\'') return failb("expected a quoted attribute value");
    const SourcePos start = here();
    advance();
    while (!at_end() && peek() != q) {
      if (peek() == '<') return failb("'<' inside an attribute value");
      if (peek() == '&') {
        if (!reference(out)) return false;
        continue;
      }
      out += peek();
      advance();
    }
    if (at_end()) {
      diags_.error(start, "unterminated attribute value");
      failed_ = true;
      return false;
    }
    advance();
    return true;
  }

  static std::string local(const std::string& n) {
    const size_t c = n.rfind(':');
    return c == std::string::npos ? n : n.substr(c + 1);
  }

  // element ::= '<' Name (S Attribute)* S? ('/>' | '>' content '</' Name S? '>')
  bool element(XmlElement& e, size_t depth) {
    if (depth > kMaxXmlDepth)
      return failb("elements nested deeper than " + std::to_string(kMaxXmlDepth));
    e.pos = here();
    advance();  // '<'
    std::string qname;
    if (!name(qname)) return false;
    e.name = local(qname);
    for (;;) {
      const bool had_space =
          !at_end() && (peek() == ' ' || peek() == '\t' || peek() == '\n' || peek() == '\r');
      skip_space();
      if (at_end()) return failb("unterminated start tag <" + qname + ">");
      if (starts("/>")) {
        advance(2);
        return true;
      }
      if (peek() == '>') {
        advance();
        break;
      }
      if (!had_space) return failb("expected white space, '>' or '/>' in <" + qname + ">");
      XmlAttribute a;
      a.pos = here();
      if (!name(a.name)) return false;
      skip_space();
      if (peek() != '=') return failb("expected '=' after attribute " + a.name);
      advance();
      skip_space();
      if (!attribute_value(a.value)) return false;
      for (const XmlAttribute& o : e.attributes) {
        if (o.name == a.name) {
          diags_.error(a.pos, "attribute " + a.name + " repeated");
          failed_ = true;
          return false;
        }
      }
      e.attributes.push_back(std::move(a));
    }
    // content
    bool plain_run = false;  // the last text appended was a plain character
    for (;;) {
      if (at_end()) {
        diags_.error(e.pos, "element <" + qname + "> is never closed");
        failed_ = true;
        return false;
      }
      if (starts("</")) {
        const SourcePos tag = here();
        advance(2);
        std::string close;
        if (!name(close)) return false;
        if (close != qname) {
          diags_.error(tag, "</" + close + "> closes <" + qname + ">");
          failed_ = true;
          return false;
        }
        skip_space();
        if (peek() != '>') return failb("expected '>' in end tag");
        advance();
        return true;
      }
      if (starts("<!--")) {
        plain_run = false;
        if (!comment()) return false;
      } else if (starts("<![CDATA[")) {
        advance(9);
        const SourcePos start = here();
        const size_t k = s_.find("]]>", i_);
        if (k == std::string_view::npos) {
          diags_.error(start, "unterminated CDATA section");
          failed_ = true;
          return false;
        }
        e.text_anchors.push_back({e.text.size(), start});
        e.text.append(s_.substr(i_, k - i_));
        advance(k + 3 - i_);
        plain_run = false;
      } else if (starts("<?")) {
        if (!skip_until("?>", "processing instruction")) return false;
      } else if (starts("<!")) {
        return failb("unexpected markup declaration");
      } else if (peek() == '<') {
        plain_run = false;
        e.children.emplace_back();
        if (!element(e.children.back(), depth + 1)) return false;
      } else if (peek() == '&') {
        e.text_anchors.push_back({e.text.size(), here()});
        if (!reference(e.text)) return false;
        plain_run = false;
      } else {
        if (!plain_run) e.text_anchors.push_back({e.text.size(), here()});
        plain_run = true;
        e.text += peek();
        advance();
      }
    }
  }

  std::string_view s_;
  DiagnosticList& diags_;
  size_t i_ = 0;
  uint32_t line_ = 1;
  uint32_t col_ = 1;
  bool failed_ = false;
};

}  // namespace

const XmlAttribute* XmlElement::attribute(std::string_view n) const {
  for (const XmlAttribute& a : attributes) {
    if (a.name == n) return &a;
  }
  return nullptr;
}

const XmlElement* XmlElement::child(std::string_view n) const {
  for (const XmlElement& c : children) {
    if (c.name == n) return &c;
  }
  return nullptr;
}

std::optional<XmlElement> parse_xml(std::string_view text, DiagnosticList& diags) {
  XmlParser p(text, diags);
  return p.document();
}

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

SourcePos XmlElement::text_position(size_t offset) const {
  if (text_anchors.empty()) return pos;
  size_t a = 0;
  while (a + 1 < text_anchors.size() && text_anchors[a + 1].offset <= offset) ++a;
  SourcePos p = text_anchors[a].pos;
  for (size_t k = text_anchors[a].offset; k < offset && k < text.size(); ++k) {
    if (text[k] == '\n') {
      ++p.line;
      p.col = 1;
    } else if ((static_cast<unsigned char>(text[k]) & 0xC0) != 0x80) {
      ++p.col;
    }
  }
  return p;
}

}  // namespace rtplc
