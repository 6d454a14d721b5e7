// Reads an IEC 61131-3 textual file into the PLCopen project model (st_file.h).
#include "lang/st/st_file.h"

#include "lang/iec/iec_functions.h"
#include "lang/plcopen/st.h"
#include "lang/sfc/ast.h"

#include <algorithm>
#include <cmath>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace rtplc::lang::st {
namespace {

using plcopen::string_close;

using plcopen::BaseType;
using plcopen::TypeRef;
using plcopen::VarSection;

bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Past whitespace, (* comments *), // comments and {pragmas} from `i`. An
// unclosed comment or pragma stops at its opener and names it in `unclosed`.
size_t skip_blank(std::string_view t, size_t i, const char*& unclosed) {
  unclosed = nullptr;
  while (i < t.size()) {
    if (std::isspace(static_cast<unsigned char>(t[i]))) {
      ++i;
    } else if (t.substr(i, 2) == "(*") {
      const size_t e = t.find("*)", i + 2);
      if (e == std::string_view::npos) {
        unclosed = "comment '(*' is never closed";
        return i;
      }
      i = e + 2;
    } else if (t.substr(i, 2) == "//") {
      const size_t e = t.find('\n', i);
      i = e == std::string_view::npos ? t.size() : e + 1;
    } else if (t[i] == '{') {
      const size_t e = plcopen::pragma_close(t, i);
      if (e == std::string_view::npos) {
        unclosed = "pragma '{' is never closed";
        return i;
      }
      i = e + 1;
    } else {
      break;
    }
  }
  return i;
}

// The text with every closed comment ((* *), //, {pragma}) turned into spaces,
// newlines kept, so every position is the file's and no reader after this
// meets a comment: a comment inside an initial value (`k : INT := 5 (* five
// *);`) or between array items is then what IEC says it is, white space.
// Strings are kept whole; an unclosed comment is left for skip() to report at
// its place. A line that starts with `(*DBG:` is OpenPLC's debugger table,
// which its runtime strips before compiling (its `(void *)` would close the
// comment early): blanked whole too.
std::string blank_comments(std::string_view t) {
  std::string out(t);
  auto blank = [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      if (out[k] != '\n' && out[k] != '\r') out[k] = ' ';
    }
  };
  bool line_start = true;
  for (size_t i = 0; i < t.size();) {
    const char c = t[i];
    if (line_start && t.substr(i, 6) == "(*DBG:") {
      const size_t e = t.find('\n', i);
      blank(i, e == std::string_view::npos ? t.size() : e);
      i = e == std::string_view::npos ? t.size() : e;
      continue;
    }
    if (c == '\n') {
      line_start = true;
      ++i;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r') {
      ++i;
      continue;
    }
    line_start = false;
    size_t e = std::string_view::npos;
    if (c == '\'' || c == '"') {
      e = string_close(t, i);
      i = e == std::string_view::npos ? t.size() : e + 1;
      continue;
    }
    if (t.substr(i, 2) == "(*") {
      e = t.find("*)", i + 2);
      if (e != std::string_view::npos) e += 2;
    } else if (t.substr(i, 2) == "//") {
      e = t.find('\n', i);
      if (e == std::string_view::npos) e = t.size();
    } else if (c == '{') {
      e = plcopen::pragma_close(t, i);
      if (e != std::string_view::npos) e += 1;
    } else {
      ++i;
      continue;
    }
    if (e == std::string_view::npos) return out;  // unclosed: skip() says where
    blank(i, e);
    i = e;
  }
  return out;
}

class Reader {
 public:
  Reader(std::string_view text, DiagnosticList& d) : owned_(blank_comments(text)), t_(owned_), d_(d) {
    line_starts_.push_back(0);
    for (size_t i = 0; i < t_.size(); ++i) {
      if (t_[i] == '\n') line_starts_.push_back(i + 1);
    }
    if (t_.substr(0, 3) == "\xEF\xBB\xBF") i_ = 3;
  }

  std::optional<plcopen::Project> read() {
    plcopen::Project p;
    std::vector<std::pair<size_t, size_t>> bodies;  // per POU: [begin, end) of its text
    skip();
    while (ok_ && i_ < t_.size()) {
      const size_t at = i_;
      const std::string w = word();
      if (w == "TYPE") {
        types(p);
      } else if (w == "PROGRAM" || w == "FUNCTION_BLOCK" || w == "FUNCTION") {
        pou(p, w, at, bodies);
      } else if (w == "CONFIGURATION") {
        configuration(p, at);
      } else {
        fail(at, w.empty() ? "unexpected '" + std::string(1, t_[at]) + "'"
                           : "'" + original(at) + "' cannot start a declaration here (TYPE, FUNCTION, "
                             "FUNCTION_BLOCK, PROGRAM or CONFIGURATION can)");
      }
      skip();
    }
    if (!ok_) return std::nullopt;
    // Each ST body is an element of the project's root holding its text, with
    // one anchor at its first character, so the ST parser's positions are the
    // file's (XmlElement::text_position).
    p.root.name = "st-file";
    size_t chart_elements = 0;
    for (const ChartText& c : charts_) chart_elements += 1 + c.actions.size();
    p.root.children.reserve(bodies.size() + marker_uses(p) + chart_elements + connections_.size());
    for (const auto& [b, e] : bodies) p.root.children.push_back(text_holder("ST", b, e));
    for (size_t k = 0; k < p.pous.size(); ++k) {
      plcopen::Body& body = p.pous[k].body;
      body.language = is_il(bodies[k].first, bodies[k].second) ? plcopen::BodyLanguage::kIl : plcopen::BodyLanguage::kSt;
      body.text = &p.root.children[k];
      body.source = p.root.children[k].text;
      body.pos = p.root.children[k].pos;
    }
    // A textual SFC body: its chart as PLCopen's <SFC> element, its actions
    // as the POU's named ST bodies (what a PLCopen project holds for them).
    for (ChartText& c : charts_) {
      plcopen::Pou& u = p.pous[c.pou];
      p.root.children.push_back(std::move(c.sfc));
      u.body.language = plcopen::BodyLanguage::kSfc;
      u.body.graph = &p.root.children.back();
      u.body.text = nullptr;
      u.body.source.clear();
      for (ChartText::Action& a : c.actions) {
        p.root.children.push_back(std::move(a.holder));
        plcopen::NamedBody nb;
        nb.name = a.name;
        nb.pos = a.pos;
        nb.body.language = a.il ? plcopen::BodyLanguage::kIl : plcopen::BodyLanguage::kSt;
        nb.body.text = &p.root.children.back();
        nb.body.source = p.root.children.back().text;
        nb.body.pos = p.root.children.back().pos;
        u.actions.push_back(std::move(nb));
      }
    }
    // Program instances' connections: each its text's element.
    for (plcopen::Configuration& c : p.configurations) {
      for (plcopen::Resource& r : c.resources) {
        auto place = [&](std::vector<plcopen::PouInstance>& instances) {
          for (plcopen::PouInstance& pi : instances) {
            for (plcopen::PouInstance::Connection& k : pi.connections) {
              auto it = connections_.find({k.pos.line, k.pos.col});
              if (it == connections_.end()) continue;
              p.root.children.push_back(std::move(it->second));
              k.text = &p.root.children.back();
            }
          }
        };
        for (plcopen::Task& t : r.tasks) place(t.instances);
        place(r.unassigned);
      }
    }
    resolve_initials(p);
    if (ok_) duplicates(p);
    if (!ok_) return std::nullopt;
    return p;
  }

 private:
  // ---- scanning ----
  SourcePos pos(size_t off) const {
    size_t lo = 0, hi = line_starts_.size();
    while (hi - lo > 1) {
      const size_t mid = (lo + hi) / 2;
      if (line_starts_[mid] <= off) lo = mid;
      else hi = mid;
    }
    uint32_t col = 1;
    for (size_t k = line_starts_[lo]; k < off && k < t_.size(); ++k) {
      if ((static_cast<unsigned char>(t_[k]) & 0xC0) != 0x80) ++col;
    }
    return SourcePos{static_cast<uint32_t>(lo + 1), col};
  }

  void fail(size_t at, const std::string& msg) {
    if (ok_) d_.error(pos(at), msg);
    ok_ = false;
  }

  // Whitespace, (* comments *), // comments and {pragmas}.
  void skip() {
    const char* unclosed = nullptr;
    i_ = skip_blank(t_, i_, unclosed);
    if (unclosed) fail(i_, unclosed);
  }

  // The identifier or keyword at the cursor, upper-case (empty: none), and past it.
  std::string word() {
    skip();
    const size_t b = i_;
    while (i_ < t_.size() && word_char(t_[i_])) ++i_;
    return plcopen::upper(t_.substr(b, i_ - b));
  }
  std::string original(size_t at) const {
    size_t e = at;
    while (e < t_.size() && word_char(t_[e])) ++e;
    return std::string(t_.substr(at, e - at));
  }
  std::string peek_word() {
    const size_t save = i_;
    std::string w = word();
    i_ = save;
    return w;
  }
  bool accept(std::string_view s) {
    skip();
    if (t_.substr(i_, s.size()) == s) {
      i_ += s.size();
      return true;
    }
    return false;
  }
  void expect(std::string_view s, const char* where) {
    if (!accept(s)) fail(i_, "expected '" + std::string(s) + "' " + where);
  }
  // A name: not a keyword of the declarations.
  std::string name(const char* what) {
    skip();
    const size_t at = i_;
    if (i_ >= t_.size() || !(std::isalpha(static_cast<unsigned char>(t_[i_])) || t_[i_] == '_')) {
      fail(at, std::string("expected ") + what);
      return {};
    }
    word();
    return original(at);
  }
  bool at_word(std::string_view w) { return peek_word() == w; }

  // The raw text up to the `;` that ends it (outside brackets and strings).
  std::string until_semicolon(const char* what) {
    skip();
    const size_t b = i_;
    int depth = 0;
    while (i_ < t_.size()) {
      const char c = t_[i_];
      if (c == '\'' || c == '"') {
        const size_t e = string_close(t_, i_);
        if (e == std::string_view::npos) break;
        i_ = e + 1;
        continue;
      }
      if (t_.substr(i_, 2) == "(*") {  // closed ones are blanked: this one never ends
        fail(i_, "comment '(*' is never closed");
        return {};
      }
      if (c == '(' || c == '[') ++depth;
      if (c == ')' || c == ']') --depth;
      if (c == ';' && depth <= 0) {
        std::string v(t_.substr(b, i_ - b));
        while (!v.empty() && std::isspace(static_cast<unsigned char>(v.back()))) v.pop_back();
        ++i_;
        return v;
      }
      ++i_;
    }
    fail(b, std::string("expected ';' after ") + what);
    return {};
  }

  // ---- structured initial values ----
  // `[1, 2, 3(0)]` and `(a := 1, b := [2, 3])` are kept as a marker naming
  // their place in the file until the whole file is read; then each becomes
  // the PLCopen form the lowering reads (<initialValue> holding an
  // <arrayValue> or <structValue>), owned by the project's root.
  std::string structured(size_t at, std::string text) {
    if (!text.empty() && text[0] == kMarker) {
      fail(at, "unexpected control character in an initial value");
      return {};
    }
    if (text.empty() || (text[0] != '[' && text[0] != '(')) return text;
    inits_.emplace_back(at, at + text.size());
    return std::string(1, kMarker) + std::to_string(inits_.size() - 1);
  }

  // [b, e) without the whitespace and comments around it.
  void trim(size_t& b, size_t& e) const {
    for (;;) {
      while (b < e && std::isspace(static_cast<unsigned char>(t_[b]))) ++b;
      while (e > b && std::isspace(static_cast<unsigned char>(t_[e - 1]))) --e;
      if (e - b >= 4 && t_.substr(b, 2) == "(*") {
        const size_t c = t_.find("*)", b + 2);
        if (c == std::string_view::npos || c + 2 > e) return;
        b = c + 2;
        continue;
      }
      return;
    }
  }

  // The items of [b, e) split at its top-level commas.
  std::vector<std::pair<size_t, size_t>> items(size_t b, size_t e) const {
    std::vector<std::pair<size_t, size_t>> out;
    int depth = 0;
    size_t start = b;
    for (size_t k = b; k < e; ++k) {
      const char c = t_[k];
      if (c == '\'' || c == '"') {
        // A comma inside a string literal is the literal's.
        const size_t close = string_close(t_, k);
        k = close == std::string_view::npos || close >= e ? e - 1 : close;
        continue;
      }
      if (c == '(' || c == '[') ++depth;
      else if (c == ')' || c == ']') --depth;
      else if (c == ',' && depth == 0) {
        out.emplace_back(start, k);
        start = k + 1;
      }
    }
    out.emplace_back(start, e);
    return out;
  }

  // One value of [b, e) as a child of `holder`: <simpleValue value="..."/>,
  // <arrayValue> or <structValue>.
  void value_into(XmlElement& holder, size_t b, size_t e, int depth) {
    trim(b, e);
    if (b >= e) return fail(b, "expected a value");
    if (depth > 16) return fail(b, "initial values nested too deeply");
    const char open = t_[b];
    if (open != '[' && open != '(') {
      XmlElement s;
      s.name = "simpleValue";
      s.pos = pos(b);
      s.attributes.push_back({"value", std::string(t_.substr(b, e - b)), pos(b)});
      holder.children.push_back(std::move(s));
      return;
    }
    const char close = open == '[' ? ']' : ')';
    if (t_[e - 1] != close) return fail(b, std::string("expected '") + close + "' to close this initial value");
    XmlElement v;
    v.name = open == '[' ? "arrayValue" : "structValue";
    v.pos = pos(b);
    for (auto [ib, ie] : items(b + 1, e - 1)) {
      if (!ok_) return;
      trim(ib, ie);
      XmlElement item;
      item.name = "value";
      item.pos = pos(ib);
      if (open == '(') {
        // member := value
        size_t n = ib;
        while (n < ie && word_char(t_[n])) ++n;
        size_t a = n;
        while (a < ie && std::isspace(static_cast<unsigned char>(t_[a]))) ++a;
        if (n == ib || t_.substr(a, 2) != ":=") return fail(ib, "expected 'member := value' in a structure's initial value");
        item.attributes.push_back({"member", std::string(t_.substr(ib, n - ib)), pos(ib)});
        value_into(item, a + 2, ie, depth + 1);
      } else {
        // n(value): the value n times
        size_t d = ib;
        while (d < ie && std::isdigit(static_cast<unsigned char>(t_[d]))) ++d;
        size_t p = d;
        while (p < ie && std::isspace(static_cast<unsigned char>(t_[p]))) ++p;
        if (d > ib && p < ie && t_[p] == '(' && t_[ie - 1] == ')') {
          item.attributes.push_back({"repetitionValue", std::string(t_.substr(ib, d - ib)), pos(ib)});
          value_into(item, p + 1, ie - 1, depth + 1);
        } else {
          value_into(item, ib, ie, depth + 1);
        }
      }
      v.children.push_back(std::move(item));
    }
    holder.children.push_back(std::move(v));
  }

  // Every marker of the project, replaced by its initial value's elements.
  // The index into inits_ that a marker names; nullopt when it is none.
  std::optional<size_t> marker_index(const std::string& initial) const {
    if (initial.empty() || initial[0] != kMarker) return std::nullopt;
    size_t index = 0;
    const auto [end, ec] = std::from_chars(initial.data() + 1, initial.data() + initial.size(), index);
    if (ec != std::errc{} || end != initial.data() + initial.size() || index >= inits_.size()) return std::nullopt;
    return index;
  }

  // How many initial values name a marker: one declaration of several names
  // (`a, b : ARRAY[0..1] OF INT := [1, 2];`) gives each the same one, and
  // each is resolved into an element of its own.
  static size_t marker_uses(const plcopen::Project& p) {
    size_t n = 0;
    auto vars = [&](const std::vector<plcopen::Variable>& vs) {
      for (const plcopen::Variable& v : vs) n += !v.initial.empty() && v.initial[0] == kMarker ? 1u : 0u;
    };
    for (const plcopen::DataType& t : p.data_types) {
      n += !t.initial.empty() && t.initial[0] == kMarker ? 1u : 0u;
      vars(t.members);
    }
    for (const plcopen::Pou& u : p.pous) vars(u.vars);
    for (const plcopen::Configuration& c : p.configurations) {
      vars(c.globals);
      for (const plcopen::Resource& r : c.resources) vars(r.globals);
    }
    return n;
  }

  // read() reserved the root's children for every one, so the bodies'
  // elements never move.
  void resolve_initials(plcopen::Project& p) {
    auto resolve = [&](std::string& initial, const XmlElement*& xml) {
      if (initial.empty() || initial[0] != kMarker || !ok_) return;
      const std::optional<size_t> index = marker_index(initial);
      if (!index || p.root.children.size() == p.root.children.capacity()) {
        initial.clear();
        return fail(0, "internal: an initial value's marker is damaged");
      }
      const auto [b, e] = inits_[*index];
      initial.clear();
      XmlElement iv;
      iv.name = "initialValue";
      iv.pos = pos(b);
      value_into(iv, b, e, 0);
      p.root.children.push_back(std::move(iv));
      xml = &p.root.children.back();
    };
    auto vars = [&](std::vector<plcopen::Variable>& vs) {
      for (plcopen::Variable& v : vs) {
        // A derived type that is no data type is a function block: its
        // instance's inputs cannot be given here yet (never dropped silently).
        if (!v.initial.empty() && v.initial[0] == kMarker && v.type.base == BaseType::kDerived && !v.type.array &&
            !p.data_type(v.type.derived)) {
          const std::optional<size_t> k = marker_index(v.initial);
          return fail(k ? inits_[*k].first : 0,
                      "initial values of function block instances are not supported yet ('" + v.name + " : " +
                          v.type.derived + "'; give its inputs in its call, docs/st.md)");
        }
        resolve(v.initial, v.initial_xml);
      }
    };
    for (plcopen::DataType& t : p.data_types) {
      resolve(t.initial, t.initial_xml);
      vars(t.members);
    }
    for (plcopen::Pou& u : p.pous) vars(u.vars);
    for (plcopen::Configuration& c : p.configurations) {
      vars(c.globals);
      for (plcopen::Resource& r : c.resources) vars(r.globals);
    }
  }

  // ---- names declared twice (as the PLCopen reader refuses them) ----
  template <class T>
  void once(const std::vector<T>& xs, const char* what, const std::string& where) {
    for (size_t i = 0; i < xs.size() && ok_; ++i) {
      for (size_t j = 0; j < i; ++j) {
        if (plcopen::iequals(xs[i].name, xs[j].name)) {
          d_.error(xs[i].pos, std::string(what) + " '" + xs[i].name + "' is declared twice" + where + " (also line " +
                                  std::to_string(xs[j].pos.line) + ")");
          ok_ = false;
          return;
        }
      }
    }
  }
  void duplicates(const plcopen::Project& p) {
    once(p.pous, "POU", "");
    once(p.data_types, "data type", "");
    for (const plcopen::DataType& t : p.data_types) {
      if (ok_ && (plcopen::elementary_type(t.name) || iec::find_iec(t.name))) {
        d_.error(t.pos, "data type '" + t.name + "' has the name of a standard type or block");
        ok_ = false;
      }
      once(t.members, "member", " in " + t.name);
    }
    for (const plcopen::Pou& u : p.pous) once(u.vars, "variable", " in " + u.name);
    for (const plcopen::Configuration& c : p.configurations) {
      std::vector<plcopen::Variable> globals = c.globals;
      for (const plcopen::Resource& r : c.resources) globals.insert(globals.end(), r.globals.begin(), r.globals.end());
      once(globals, "global variable", " in " + c.name);
      once(c.resources, "resource", " in " + c.name);
      std::vector<plcopen::Task> tasks;
      for (const plcopen::Resource& r : c.resources) tasks.insert(tasks.end(), r.tasks.begin(), r.tasks.end());
      once(tasks, "task", " in " + c.name);
    }
  }

  // ---- types ----
  std::optional<int64_t> integer() {
    skip();
    const size_t b = i_;
    if (i_ < t_.size() && (t_[i_] == '-' || t_[i_] == '+')) ++i_;
    while (i_ < t_.size() && (std::isdigit(static_cast<unsigned char>(t_[i_])) || t_[i_] == '_')) ++i_;
    const auto v = plcopen::parse_literal(t_.substr(b, i_ - b));
    if (!v || b == i_) {
      fail(b, "expected a whole number (array bounds and subranges are constants)");
      return std::nullopt;
    }
    // (as PLCopen's array bounds: a bound farther out could not be an index)
    if (std::fabs(*v) > 1e9) {
      fail(b, "the bound " + std::string(t_.substr(b, std::min<size_t>(i_ - b, 24))) +
                  " is out of range (at most 1,000,000,000 either way)");
      return std::nullopt;
    }
    return static_cast<int64_t>(*v);
  }

  std::optional<TypeRef> type_ref(const char* what) {
    skip();
    const size_t at = i_;
    const std::string w = word();
    if (w.empty()) {
      fail(at, std::string("expected the type of ") + what);
      return std::nullopt;
    }
    if (w == "ARRAY") {
      auto a = std::make_shared<plcopen::ArrayType>();
      expect("[", "after ARRAY");
      do {
        const auto lo = integer();
        expect("..", "between an array's bounds");
        const auto hi = integer();
        if (!ok_) return std::nullopt;
        if (*hi < *lo) {
          fail(at, "array bounds " + std::to_string(*lo) + ".." + std::to_string(*hi) + " are empty");
          return std::nullopt;
        }
        a->dims.emplace_back(*lo, *hi);
      } while (accept(","));
      expect("]", "after an array's bounds");
      if (word() != "OF") fail(i_, "expected OF after ARRAY [...]");
      const auto el = type_ref("the array's elements");
      if (!ok_ || !el) return std::nullopt;
      a->element = *el;
      if (a->size() > plcopen::kMaxArrayElements) {
        fail(at, "array of " + std::to_string(a->size()) + " elements: a task's arrays hold at most " +
                     std::to_string(plcopen::kMaxArrayElements));
        return std::nullopt;
      }
      TypeRef r;
      r.base = BaseType::kDerived;
      r.array = std::move(a);
      return r;
    }
    if (w == "STRING" || w == "HMI_STRING" || w == "WSTRING" || w == "HMI_WSTRING") {
      TypeRef r;
      r.base = w == "STRING" || w == "HMI_STRING" ? BaseType::kString : BaseType::kWString;
      r.hmi = w.rfind("HMI_", 0) == 0;
      skip();
      // STRING[n] (IEC) or STRING(n) (CODESYS): the most characters it holds.
      const char open = i_ < t_.size() ? t_[i_] : '\0';
      if (open == '[' || open == '(') {
        ++i_;
        skip();
        const size_t len_at = i_;
        const auto len = integer();
        if (!len) return std::nullopt;
        const long n = static_cast<long>(*len);
        if (n < 1 || n > static_cast<long>(kMaxStringLength)) {
          fail(len_at, "a STRING of " + std::to_string(n) + " characters: 1 to " + std::to_string(kMaxStringLength));
          return std::nullopt;
        }
        r.string_len = static_cast<uint32_t>(n);
        expect(open == '[' ? "]" : ")", "after a STRING's length");
        if (!ok_) return std::nullopt;
      }
      return r;
    }
    if (w == "POINTER" || w == "REF_TO") {
      fail(at, "type " + w + " is not supported (docs/st.md)");
      return std::nullopt;
    }
    TypeRef r;
    if (auto b = plcopen::elementary_type(w)) {
      r.base = *b;
      r.hmi = plcopen::is_hmi_type(w);
    } else {
      r.base = BaseType::kDerived;
      r.derived = original(at);
    }
    // A subrange INT (0..100): its base type (the range is not checked at run
    // time, as for PLCopen's subranges).
    skip();
    if (t_.substr(i_, 1) == "(" && r.base != BaseType::kDerived) {
      ++i_;
      integer();
      expect("..", "in a subrange");
      integer();
      expect(")", "after a subrange");
    }
    return r;
  }

  void types(plcopen::Project& p) {
    while (ok_) {
      skip();
      if (at_word("END_TYPE")) {
        word();
        accept(";");
        return;
      }
      const size_t at = i_;
      plcopen::DataType dt;
      dt.name = name("a type name or END_TYPE");
      dt.pos = pos(at);
      expect(":", "after the type's name");
      if (!ok_) return;
      skip();
      if (accept("(")) {
        dt.kind = plcopen::DataType::Kind::kEnum;
        do {
          dt.values.push_back(name("an enumeration value"));
          int number = dt.numbers.empty() ? 0 : dt.numbers.back() + 1;
          if (accept(":=")) {
            const auto k = integer();
            if (!ok_ || !k) return;
            number = static_cast<int>(*k);
          }
          dt.numbers.push_back(number);
        } while (ok_ && accept(","));
        expect(")", "after the enumeration's values");
      } else if (at_word("STRUCT")) {
        word();
        dt.kind = plcopen::DataType::Kind::kStruct;
        while (ok_ && !at_word("END_STRUCT")) declaration(dt.members, VarSection::kLocal, false);
        word();
      } else {
        const auto t = type_ref("the type");
        if (!ok_ || !t) return;
        if (t->array) {
          dt.kind = plcopen::DataType::Kind::kArray;
          dt.array = t->array;
        } else {
          dt.kind = plcopen::DataType::Kind::kAlias;
          dt.alias = *t;
        }
      }
      if (accept(":=")) {
        skip();
        const size_t iat = i_;
        dt.initial = structured(iat, until_semicolon("the type's initial value"));
      } else {
        expect(";", "after a type declaration");
      }
      p.data_types.push_back(std::move(dt));
    }
  }

  // ---- variables ----
  // One `a, b AT %IX0.0 : TYPE := init;` line into `out`.
  void declaration(std::vector<plcopen::Variable>& out, VarSection s, bool constant) {
    std::vector<std::pair<std::string, size_t>> names;
    do {
      skip();
      const size_t at = i_;
      names.emplace_back(name("a variable name"), at);
    } while (ok_ && accept(","));
    std::string address;
    if (ok_ && at_word("AT")) {
      word();
      skip();
      const size_t b = i_;
      while (i_ < t_.size() && (word_char(t_[i_]) || t_[i_] == '%' || t_[i_] == '.' || t_[i_] == '*')) ++i_;
      address = std::string(t_.substr(b, i_ - b));
      if (address.empty() || address[0] != '%') fail(b, "expected a located address such as %IX0.0 after AT");
    }
    expect(":", "after the variable's name");
    if (!ok_) return;
    const auto type = type_ref(names.front().first.c_str());
    if (!ok_ || !type) return;
    char edge = 0;
    skip();
    if (at_word("R_EDGE") || at_word("F_EDGE")) {
      const size_t eat = i_;
      edge = word()[0];
      if (s != VarSection::kInput || !type->is_bool() || type->array) {
        fail(eat, std::string(edge == 'R' ? "R_EDGE" : "F_EDGE") +
                      " qualifies a BOOL input (VAR_INPUT) of a function block only");
        return;
      }
    }
    std::string initial;
    if (accept(":=")) {
      skip();
      const size_t iat = i_;
      initial = structured(iat, until_semicolon("the initial value"));
    } else {
      expect(";", "after a declaration");
    }
    for (const auto& [n, at] : names) {
      plcopen::Variable v;
      v.name = n;
      v.type = *type;
      v.section = s;
      v.address = address;
      v.initial = initial;
      v.constant = constant;
      v.edge = edge;
      v.pos = pos(at);
      out.push_back(std::move(v));
    }
  }

  // VAR ... END_VAR sections while there are some; false on a word that starts none.
  void var_sections(std::vector<plcopen::Variable>& out, bool globals_only) {
    static const std::pair<const char*, VarSection> kSections[] = {
        {"VAR", VarSection::kLocal},        {"VAR_INPUT", VarSection::kInput},
        {"VAR_OUTPUT", VarSection::kOutput}, {"VAR_IN_OUT", VarSection::kInOut},
        {"VAR_TEMP", VarSection::kTemp},     {"VAR_EXTERNAL", VarSection::kExternal},
        {"VAR_GLOBAL", VarSection::kGlobal},
    };
    while (ok_) {
      skip();
      const size_t at = i_;
      const std::string w = peek_word();
      const auto* sec = std::find_if(std::begin(kSections), std::end(kSections),
                                     [&](const auto& k) { return w == k.first; });
      if (sec == std::end(kSections)) return;
      if (globals_only && sec->second != VarSection::kGlobal) {
        fail(at, w + " cannot be declared here (VAR_GLOBAL can)");
        return;
      }
      word();
      bool constant = false;
      for (;;) {
        const std::string q = peek_word();
        if (q == "CONSTANT") constant = true;
        else if (q != "RETAIN" && q != "NON_RETAIN" && q != "PERSISTENT") break;
        word();  // retention is the runtime's (docs/runtime.md), as for PLCopen projects
      }
      while (ok_ && !at_word("END_VAR")) {
        skip();
        if (i_ >= t_.size()) return fail(at, w + " is never closed by END_VAR");
        declaration(out, sec->second, constant);
      }
      word();
    }
  }

  // ---- program organisation units ----
  void pou(plcopen::Project& p, const std::string& kind, size_t at, std::vector<std::pair<size_t, size_t>>& bodies) {
    plcopen::Pou u;
    u.name = name("the POU's name");
    u.pos = pos(at);
    u.type = kind == "PROGRAM" ? plcopen::PouType::kProgram
             : kind == "FUNCTION_BLOCK" ? plcopen::PouType::kFunctionBlock
                                        : plcopen::PouType::kFunction;
    if (u.type == plcopen::PouType::kFunction) {
      expect(":", "after the function's name (its return type follows)");
      if (!ok_) return;
      u.return_type = type_ref("the function's result");
    }
    var_sections(u.vars, false);
    if (!ok_) return;
    skip();
    const size_t b = i_;
    const std::string end = "END_" + kind;
    // The body runs to the first END_<kind> outside comments and strings.
    size_t k = i_;
    while (k < t_.size()) {
      const char c = t_[k];
      if (t_.substr(k, 2) == "(*") {
        const size_t e = t_.find("*)", k + 2);
        k = e == std::string_view::npos ? t_.size() : e + 2;
      } else if (t_.substr(k, 2) == "//") {
        const size_t e = t_.find('\n', k);
        k = e == std::string_view::npos ? t_.size() : e;
      } else if (c == '\'' || c == '"') {
        const size_t e = string_close(t_, k);
        k = e == std::string_view::npos ? t_.size() : e + 1;
      } else if (word_char(c) && (k == 0 || !word_char(t_[k - 1]))) {
        size_t e = k;
        while (e < t_.size() && word_char(t_[e])) ++e;
        if (plcopen::upper(t_.substr(k, e - k)) == end) break;
        k = e;
      } else {
        ++k;
      }
    }
    if (k >= t_.size()) return fail(at, kind + " " + u.name + " is never closed by " + end);
    bodies.emplace_back(b, k);
    if (starts_chart(b, k)) {
      if (u.type == plcopen::PouType::kFunction) {
        return fail(b, "FUNCTION " + u.name + ": a function's body cannot be an SFC (a function keeps nothing "
                       "between calls); make it a FUNCTION_BLOCK or PROGRAM");
      }
      i_ = b;
      chart(p.pous.size(), k);
      if (!ok_) return;
    }
    i_ = k + end.size();
    accept(";");
    p.pous.push_back(std::move(u));
  }

  // ---- IL bodies ----
  // A POU body in IL (MatIEC reads both languages in one file): its first
  // word is an IL operator followed by an operand on the same line, or a
  // label `name:` before one; `LD := 1;` (a variable named LD) stays ST.
  bool is_il(size_t b, size_t e) {
    static const char* const kOps[] = {"LD",   "LDN",  "ST",   "STN",  "S",    "R",    "AND",  "ANDN",  "OR",
                                       "ORN",  "XOR",  "XORN", "NOT",  "ADD",  "SUB",  "MUL",  "DIV",   "MOD",
                                       "GT",   "GE",   "EQ",   "NE",   "LE",   "LT",   "JMP",  "JMPC",  "JMPCN",
                                       "CAL",  "CALC", "CALCN", "RET", "RETC", "RETCN"};
    const size_t save = i_;
    i_ = b;
    std::string w = word();
    if (i_ < e && t_[i_] == ':' && (i_ + 1 >= t_.size() || t_[i_ + 1] != '=')) {  // a label
      ++i_;
      w = word();
    }
    bool op_word = false;
    for (const char* op : kOps) op_word = op_word || w == op;
    bool il = i_ <= e && op_word;
    if (il) {
      // What follows is an operand (or, on the next line, the next
      // instruction after RET or NOT), not the `:=`, `(`, `[`, `.` or `;` of
      // an ST statement about a variable named like the operator.
      size_t k = i_;
      while (k < e && std::isspace(static_cast<unsigned char>(t_[k]))) ++k;
      il = k >= e || (t_[k] != ':' && t_[k] != ';' && t_[k] != '(' && t_[k] != '[' && t_[k] != '.' && t_[k] != '=');
      // An IL instruction ends with its line, an ST statement with `;`
      // (`JMP next;` is ST's JMP).
      for (size_t j = i_; il && j < e && t_[j] != '\n'; ++j) il = t_[j] != ';';
    }
    i_ = save;
    return il;
  }

  // ---- textual SFC (docs/st.md, "Textual SFC") ----
  // A POU body that starts with INITIAL_STEP, STEP, TRANSITION or ACTION is a
  // chart (IEC 61131-3's sequential_function_chart, as Beremiz writes an SFC
  // POU into the .st file it gives MatIEC). It is read into the element a
  // PLCopen project holds for a drawn chart, so one SFC lowering (and one set
  // of rules, lang/sfc) runs both:
  //   <step name initialStep> with a <connectionPointIn> per transition into it
  //   <transition> connected to the steps it leaves, its condition inline ST
  //     (`:= expression;`) or IL (`: instructions`), in priority order, then
  //     file order (the order that decides a selection)
  //   <actionBlock> per step, an <action qualifier duration><reference> per
  //     association
  // and each ACTION ... END_ACTION is a named ST body of the POU.
  struct ChartText {
    size_t pou = 0;
    XmlElement sfc;
    struct Action {
      std::string name;
      SourcePos pos;
      XmlElement holder;
      bool il = false;  // its body is IL (is_il)
    };
    std::vector<Action> actions;
  };

  static bool chart_word(const std::string& w) {
    return w == "INITIAL_STEP" || w == "STEP" || w == "TRANSITION" || w == "ACTION";
  }
  // The body [b, e) starts a chart: `INITIAL_STEP s :`, `STEP s :`,
  // `ACTION a :` (not `:=`), or `TRANSITION` before a name, `(` or FROM;
  // `step := step + 1;` (a variable named STEP) stays ST.
  bool starts_chart(size_t b, size_t e) {
    const size_t save = i_;
    i_ = b;
    const std::string w = word();
    bool chart = i_ <= e && chart_word(w);
    if (chart) {
      skip();
      const bool name_next = i_ < e && (std::isalpha(static_cast<unsigned char>(t_[i_])) || t_[i_] == '_');
      if (w == "TRANSITION") {
        chart = name_next || (i_ < e && t_[i_] == '(');
      } else {
        word();
        skip();
        chart = name_next && i_ < e && t_[i_] == ':' && (i_ + 1 >= e || t_[i_ + 1] != '=');
      }
    }
    i_ = save;
    return chart;
  }

  static XmlElement element(std::string name, SourcePos pos, std::vector<XmlAttribute> attrs = {}) {
    XmlElement x;
    x.name = std::move(name);
    x.pos = pos;
    x.attributes = std::move(attrs);
    return x;
  }
  // A text holder whose positions are the file's: [b, e) of the file.
  XmlElement text_holder(const char* name, size_t b, size_t e) const {
    XmlElement x = element(name, pos(b));
    x.text = std::string(t_.substr(b, e - b));
    x.text_anchors.push_back({0, pos(b)});
    return x;
  }
  static XmlElement connected(const std::vector<std::string>& ids, SourcePos pos) {
    XmlElement in = element("connectionPointIn", pos);
    for (const std::string& id : ids) in.children.push_back(element("connection", pos, {{"refLocalId", id, pos}}));
    return in;
  }

  // The end of the body text [i_, e) that runs to keyword `end` (outside
  // strings; comments are blanked already); e when it never comes.
  size_t keyword_at(const std::string& end, size_t e) const {
    size_t k = i_;
    while (k < e) {
      const char c = t_[k];
      if (c == '\'' || c == '"') {
        const size_t q = string_close(t_, k);
        k = q == std::string_view::npos || q >= e ? e : q + 1;
      } else if (word_char(c) && (k == 0 || !word_char(t_[k - 1]))) {
        size_t w = k;
        while (w < e && word_char(t_[w])) ++w;
        if (plcopen::upper(t_.substr(k, w - k)) == end) return k;
        k = w;
      } else {
        ++k;
      }
    }
    return e;
  }

  // One step, transition or action after another up to `e` (the END_PROGRAM
  // or END_FUNCTION_BLOCK); the POU is p.pous[pou] once read.
  void chart(size_t pou, size_t e) {
    struct StepText {
      std::string name;
      size_t at = 0;
      bool initial = false;
      std::vector<XmlElement> actions;  // <action> elements
    };
    struct TransitionText {
      size_t at = 0;
      long priority = 0;        // 0 without PRIORITY, as MatIEC counts it
      bool prioritised = false;
      std::vector<std::pair<std::string, size_t>> from, to;  // step name, where
      XmlElement condition;
    };
    std::vector<StepText> steps;
    std::vector<TransitionText> transitions;
    ChartText c;
    c.pou = pou;
    auto steps_list = [&](std::vector<std::pair<std::string, size_t>>& out, const char* what) {
      const bool several = accept("(");
      do {
        skip();
        const size_t at = i_;
        const std::string n = name(what);
        if (!ok_) return;
        out.emplace_back(n, at);
      } while (several && accept(","));
      if (several) expect(")", "after the steps of a transition");
    };
    while (ok_) {
      skip();
      if (i_ >= e) break;
      const size_t at = i_;
      const std::string w = word();
      if (w == "INITIAL_STEP" || w == "STEP") {
        StepText st;
        st.at = at;
        st.initial = w == "INITIAL_STEP";
        st.name = name("the step's name");
        expect(":", "after the step's name");
        while (ok_ && !at_word("END_STEP")) {
          skip();
          if (i_ >= e) return fail(at, w + " " + st.name + " is never closed by END_STEP");
          st.actions.push_back(association());
          expect(";", "after an action association");
        }
        if (!ok_) return;
        word();  // END_STEP
        accept(";");
        steps.push_back(std::move(st));
      } else if (w == "TRANSITION") {
        TransitionText tr;
        tr.at = at;
        skip();
        if (!at_word("FROM") && !(i_ < e && t_[i_] == '(')) name("the transition's name");
        if (accept("(")) {
          skip();
          const size_t p_at = i_;
          if (word() != "PRIORITY") return fail(p_at, "expected PRIORITY := n in a transition's parentheses");
          expect(":=", "after PRIORITY");
          skip();
          const size_t n_at = i_;
          long n = 0;
          while (i_ < e && std::isdigit(static_cast<unsigned char>(t_[i_])) && n < 1'000'000) n = n * 10 + (t_[i_++] - '0');
          if (i_ == n_at || n >= 1'000'000) return fail(n_at, "a transition's PRIORITY is a whole number from 0 to 999999");
          tr.priority = n;
          tr.prioritised = true;
          expect(")", "after the transition's priority");
        }
        skip();
        const size_t from_at = i_;
        if (word() != "FROM") return fail(from_at, "expected FROM and the steps the transition leaves");
        steps_list(tr.from, "a step the transition leaves");
        skip();
        const size_t to_at = i_;
        if (ok_ && word() != "TO") return fail(to_at, "expected TO and the steps the transition enters");
        steps_list(tr.to, "a step the transition enters");
        if (!ok_) return;
        XmlElement inl = element("inline", pos(i_), {{"name", "", pos(i_)}});
        if (accept(":=")) {
          skip();
          const size_t b = i_;
          const size_t end_kw = keyword_at("END_TRANSITION", e);
          until_semicolon("the transition's condition");
          if (!ok_) return;
          if (i_ > end_kw) return fail(b, "expected ';' after the transition's condition, before END_TRANSITION");
          size_t ce = i_ - 1;  // the ';'
          XmlElement st = element("ST", pos(b));
          st.children.push_back(text_holder("xhtml", b, ce));
          inl.children.push_back(std::move(st));
        } else if (accept(":")) {
          // IL: the current result at the end of the instructions.
          skip();
          const size_t b = i_;
          const size_t ce = keyword_at("END_TRANSITION", e);
          XmlElement il = element("IL", pos(b));
          il.children.push_back(text_holder("xhtml", b, ce));
          inl.children.push_back(std::move(il));
          i_ = ce;
        } else {
          return fail(i_, "expected ':=' and the transition's condition");
        }
        skip();
        const size_t end_at = i_;
        if (word() != "END_TRANSITION") return fail(end_at, "expected END_TRANSITION");
        accept(";");
        tr.condition = element("condition", pos(at));
        tr.condition.children.push_back(std::move(inl));
        transitions.push_back(std::move(tr));
      } else if (w == "ACTION") {
        ChartText::Action a;
        a.pos = pos(at);
        a.name = name("the action's name");
        expect(":", "after the action's name");
        if (!ok_) return;
        for (const ChartText::Action& other : c.actions) {
          if (plcopen::iequals(other.name, a.name)) return fail(at, "ACTION " + a.name + " is declared twice");
        }
        const size_t b = i_;
        const size_t ae = keyword_at("END_ACTION", e);
        if (ae >= e) return fail(at, "ACTION " + a.name + " is never closed by END_ACTION");
        a.holder = text_holder("ST", b, ae);
        a.il = is_il(b, ae);
        i_ = ae + std::string_view("END_ACTION").size();
        accept(";");
        c.actions.push_back(std::move(a));
      } else {
        return fail(at, (w.empty() ? "'" + std::string(1, t_[at]) + "'" : "'" + original(at) + "'") +
                            " cannot stand in a textual SFC: a body that starts with a step is a chart of "
                            "INITIAL_STEP, STEP, TRANSITION and ACTION, no statements between them");
      }
    }
    if (!ok_) return;
    // The elements, with localIds: steps 1..n, transitions after them.
    std::map<std::string, size_t> step_index;
    for (size_t k = 0; k < steps.size(); ++k) {
      if (!step_index.emplace(plcopen::upper(steps[k].name), k).second) {
        return fail(steps[k].at, "step " + steps[k].name + " is declared twice");
      }
    }
    // The order transitions are tried in, as MatIEC lists them: one without
    // a PRIORITY (counted as 0) goes last, one with goes before the first
    // whose priority is larger.
    std::vector<size_t> order;
    for (size_t k = 0; k < transitions.size(); ++k) {
      if (!transitions[k].prioritised) {
        order.push_back(k);
        continue;
      }
      auto it = order.begin();
      while (it != order.end() && transitions[*it].priority <= transitions[k].priority) ++it;
      order.insert(it, k);
    }
    std::vector<std::vector<std::string>> into(steps.size());
    std::vector<XmlElement> transition_elements;
    for (size_t n = 0; n < order.size(); ++n) {
      TransitionText& tr = transitions[order[n]];
      const std::string id = std::to_string(steps.size() + 1 + n);
      // Each step a transition names, as its index; nullopt (reported) when undeclared.
      auto step_of = [&](const std::pair<std::string, size_t>& named) -> std::optional<size_t> {
        auto it = step_index.find(plcopen::upper(named.first));
        if (it == step_index.end()) {
          fail(named.second, "step " + named.first + " is not declared in this chart");
          return std::nullopt;
        }
        return it->second;
      };
      std::vector<std::string> from;
      for (const auto& named : tr.from) {
        const auto k = step_of(named);
        if (!k) return;
        from.push_back(std::to_string(*k + 1));
      }
      for (const auto& named : tr.to) {
        const auto k = step_of(named);
        if (!k) return;
        into[*k].push_back(id);
      }
      XmlElement t = element("transition", pos(tr.at), {{"localId", id, pos(tr.at)}});
      t.children.push_back(connected(from, pos(tr.at)));
      t.children.push_back(std::move(tr.condition));
      transition_elements.push_back(std::move(t));
    }
    c.sfc = element("SFC", pos(steps.empty() ? i_ : steps.front().at));
    size_t block_id = steps.size() + transitions.size();
    std::vector<XmlElement> blocks;
    for (size_t k = 0; k < steps.size(); ++k) {
      StepText& st = steps[k];
      const SourcePos sp = pos(st.at);
      XmlElement x = element("step", sp,
                             {{"localId", std::to_string(k + 1), sp},
                              {"name", st.name, sp},
                              {"initialStep", st.initial ? "true" : "false", sp}});
      if (!into[k].empty()) x.children.push_back(connected(into[k], sp));
      c.sfc.children.push_back(std::move(x));
      if (st.actions.empty()) continue;
      XmlElement ab = element("actionBlock", sp, {{"localId", std::to_string(++block_id), sp}});
      ab.children.push_back(connected({std::to_string(k + 1)}, sp));
      for (XmlElement& a : st.actions) ab.children.push_back(std::move(a));
      blocks.push_back(std::move(ab));
    }
    for (XmlElement& t : transition_elements) c.sfc.children.push_back(std::move(t));
    for (XmlElement& b : blocks) c.sfc.children.push_back(std::move(b));
    charts_.push_back(std::move(c));
  }

  // `name(qualifier[, duration])` in a step: an <action> element.
  XmlElement association() {
    skip();
    const size_t at = i_;
    const SourcePos p = pos(at);
    const std::string target = name("an action or BOOL variable");
    XmlElement a = element("action", p);
    if (!ok_) return a;
    expect("(", "after the action's name (its qualifier: N, S, R, P, P0, P1, L, D, SD, DS, SL)");
    std::string qualifier = "N";
    if (!accept(")")) {
      skip();
      const size_t q_at = i_;
      qualifier = word();
      if (qualifier.empty()) {
        fail(q_at, "expected the action's qualifier (N, S, R, P, P0, P1, L, D, SD, DS, SL)");
        return a;
      }
      // The timed qualifiers' duration first; what follows is indicators.
      if (sfc::is_timed_qualifier(qualifier) && accept(",")) {
        skip();
        const size_t d_at = i_;
        size_t d = i_;
        while (d < t_.size() && t_[d] != ',' && t_[d] != ')') ++d;
        std::string duration(t_.substr(i_, d - i_));
        while (!duration.empty() && std::isspace(static_cast<unsigned char>(duration.back()))) duration.pop_back();
        if (duration.empty()) {
          fail(d_at, "expected the action's duration, a TIME literal (T#2s) or a TIME variable");
          return a;
        }
        a.attributes.push_back({"duration", duration, pos(d_at)});
        i_ = d;
      }
      // Indicator variables (`a(N, done_flag)`): IEC shows them beside the
      // action; they change nothing, and MatIEC's code ignores them too.
      while (ok_ && accept(",")) name("an indicator variable");
      expect(")", "after the action's qualifier");
    }
    a.attributes.push_back({"qualifier", qualifier, p});
    a.children.push_back(element("reference", p, {{"name", target, p}}));
    return a;
  }

  // ---- configurations ----
  void configuration(plcopen::Project& p, size_t at) {
    plcopen::Configuration c;
    c.name = name("the configuration's name");
    c.pos = pos(at);
    var_sections(c.globals, true);
    plcopen::Resource implicit;  // TASK and PROGRAM directly in the configuration
    implicit.name = c.name;
    implicit.pos = c.pos;
    while (ok_) {
      skip();
      const size_t wat = i_;
      const std::string w = word();
      if (w == "END_CONFIGURATION") {
        accept(";");
        break;
      }
      if (w == "RESOURCE") {
        plcopen::Resource r;
        r.name = name("the resource's name");
        r.pos = pos(wat);
        if (word() != "ON") return fail(i_, "expected ON and the resource's processor after RESOURCE " + r.name);
        name("the resource's processor");
        var_sections(r.globals, true);
        while (ok_ && !at_word("END_RESOURCE")) {
          if (i_ >= t_.size()) return fail(wat, "RESOURCE " + r.name + " is never closed by END_RESOURCE");
          resource_item(r);
        }
        word();
        accept(";");
        c.resources.push_back(std::move(r));
      } else if (w == "TASK" || w == "PROGRAM") {
        i_ = wat;
        resource_item(implicit);
      } else if (i_ >= t_.size() && w.empty()) {
        return fail(at, "CONFIGURATION " + c.name + " is never closed by END_CONFIGURATION");
      } else {
        return fail(wat, "'" + original(wat) + "' cannot stand in a configuration (RESOURCE, TASK, PROGRAM or "
                         "END_CONFIGURATION can)");
      }
    }
    if (!implicit.tasks.empty() || !implicit.unassigned.empty()) c.resources.push_back(std::move(implicit));
    p.configurations.push_back(std::move(c));
  }

  void resource_item(plcopen::Resource& r) {
    skip();
    const size_t at = i_;
    const std::string w = word();
    if (w == "TASK") {
      plcopen::Task t;
      t.name = name("the task's name");
      t.pos = pos(at);
      expect("(", "after the task's name");
      while (ok_ && !accept(")")) {
        const size_t pat = i_;
        const std::string key = word();
        expect(":=", "after a task property");
        const std::string v = until_property();
        if (key == "INTERVAL") {
          bool is_time = false;
          const auto s = plcopen::parse_literal(v, nullptr, &is_time);
          if (!s || !is_time || *s <= 0) return fail(pat, "INTERVAL := " + v + ": expected a TIME such as T#20ms");
          t.interval = *s;
        } else if (key == "PRIORITY") {
          const auto pr = plcopen::parse_literal(v);
          if (!pr || !(*pr >= 0 && *pr <= 1000000) || *pr != std::floor(*pr)) {
            return fail(pat, "PRIORITY := " + v + ": expected a whole number from 0 to 1000000");
          }
          t.priority = static_cast<int>(*pr);
        } else if (key == "SINGLE") {
          t.single = v;
        } else {
          return fail(pat, "a task has INTERVAL, PRIORITY and SINGLE, not '" + original(pat) + "'");
        }
        accept(",");
      }
      accept(";");
      r.tasks.push_back(std::move(t));
    } else if (w == "PROGRAM") {
      const std::string q = peek_word();
      if (q == "RETAIN" || q == "NON_RETAIN") word();
      plcopen::PouInstance pi;
      pi.name = name("the program instance's name");
      pi.pos = pos(at);
      std::string task;
      if (at_word("WITH")) {
        word();
        task = name("the task after WITH");
      }
      expect(":", "before the program's type");
      pi.type_name = name("the program's type");
      skip();
      if (accept("(")) {
        // (input := constant | global | %I..., output => global | %Q..., ...)
        while (ok_ && !accept(")")) {
          skip();
          const size_t c_at = i_;
          plcopen::PouInstance::Connection c;
          c.formal = name("a variable of the program to connect");
          c.pos = pos(c_at);
          if (accept(":=")) {
            c.output = false;
          } else if (accept("=>")) {
            c.output = true;
          } else {
            return fail(i_, "expected ':=' (an input's source) or '=>' (an output's sink) after '" + c.formal + "'");
          }
          skip();
          const size_t b = i_;
          size_t e = i_;
          int depth = 0;
          while (e < t_.size() && depth >= 0 && !(depth == 0 && (t_[e] == ',' || t_[e] == ')'))) {
            if (t_[e] == '(' || t_[e] == '[') ++depth;
            if (t_[e] == ')' || t_[e] == ']') --depth;
            if (t_[e] == '\'' || t_[e] == '"') {
              const size_t close = string_close(t_, e);
              if (close == std::string_view::npos) break;
              e = close;
            }
            ++e;
          }
          size_t te = e;
          while (te > b && std::isspace(static_cast<unsigned char>(t_[te - 1]))) --te;
          if (te == b || depth < 0 || e >= t_.size()) {
            return fail(b, "expected the connection's " + std::string(c.output ? "sink" : "source") +
                               ", then ',' or ')'");
          }
          for (const plcopen::PouInstance::Connection& other : pi.connections) {
            if (plcopen::iequals(other.formal, c.formal)) return fail(c_at, "'" + c.formal + "' is connected twice");
          }
          // Its text's element, found by the connection's place once read()
          // has put the holders where they stay.
          connections_.emplace(std::pair{c.pos.line, c.pos.col}, text_holder("ST", b, te));
          pi.connections.push_back(std::move(c));
          i_ = e;
          accept(",");
        }
      }
      accept(";");
      if (!ok_) return;
      if (task.empty()) {
        r.unassigned.push_back(std::move(pi));
        return;
      }
      for (plcopen::Task& t : r.tasks) {
        if (plcopen::iequals(t.name, task)) {
          t.instances.push_back(std::move(pi));
          return;
        }
      }
      fail(at, "PROGRAM " + pi.name + " WITH " + task + ": no task " + task + " is declared before it");
    } else {
      fail(at, "'" + original(at) + "' cannot stand in a resource (TASK, PROGRAM, VAR_GLOBAL or END_RESOURCE "
               "can)");
    }
  }

  // A task property's value: up to the next ',' or ')'.
  std::string until_property() {
    skip();
    const size_t b = i_;
    while (i_ < t_.size() && t_[i_] != ',' && t_[i_] != ')') ++i_;
    std::string v(t_.substr(b, i_ - b));
    while (!v.empty() && std::isspace(static_cast<unsigned char>(v.back()))) v.pop_back();
    return v;
  }

  std::vector<ChartText> charts_;
  std::map<std::pair<uint32_t, uint32_t>, XmlElement> connections_;  // line:col -> source or sink text
  static constexpr char kMarker = '\x01';  // never in a valid initial value's text
  std::vector<std::pair<size_t, size_t>> inits_;
  std::string owned_;  // the file with its comments blanked (blank_comments)
  std::string_view t_;
  DiagnosticList& d_;
  size_t i_ = 0;
  bool ok_ = true;
  std::vector<size_t> line_starts_;
};

}  // namespace

std::optional<plcopen::Project> read_st_file(std::string_view text, DiagnosticList& diags) {
  return Reader(text, diags).read();
}

bool is_st_source(std::string_view text) {
  const char* unclosed = nullptr;
  const size_t i = skip_blank(text, text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0, unclosed);
  if (unclosed) return false;
  size_t e = i;
  while (e < text.size() && word_char(text[e])) ++e;
  const std::string w = plcopen::upper(text.substr(i, e - i));
  return w == "PROGRAM" || w == "FUNCTION_BLOCK" || w == "FUNCTION" || w == "TYPE" || w == "CONFIGURATION";
}

}  // namespace rtplc::lang::st
