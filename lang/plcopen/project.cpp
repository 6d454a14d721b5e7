// PLCopen XML -> project model (see project.h).
#include "lang/plcopen/project.h"

#include <cctype>
#include <cmath>
#include <cstdlib>

#include "blocks/int_math.h"
#include "blocks/string_ops.h"
#include "common/text.h"
#include "lang/iec/iec_functions.h"

namespace rtplc::lang::plcopen {

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(a[i])) != std::toupper(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}

std::string upper(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return r;
}

std::string attr(const XmlElement& e, std::string_view n) {
  const XmlAttribute* a = e.attribute(n);
  return a ? a->value : std::string();
}

bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

namespace {

const char* const kNamespaces[] = {
    "http://www.plcopen.org/xml/tc6_0201",
    "http://www.plcopen.org/xml/tc6_0200",
    "http://www.plcopen.org/xml/tc6.xsd",
};

// A task interval in seconds: a TIME literal (T#20ms, tc6_0201), an XML
// duration (PT0.02S, what the tc6_0200 schema types it as) or an XML time of
// day (00:00:00.100000, the legacy tc6.xsd).
std::optional<double> parse_interval(const std::string& text) {
  bool is_time = false;
  if (auto v = parse_literal(text, nullptr, &is_time); v && is_time) return v;
  const char* p = text.c_str();
  char* end = nullptr;
  if (text.size() > 1 && (p[0] == 'P' || p[0] == 'p')) {
    double total = 0;
    bool in_time = false, any = false;
    ++p;
    while (*p) {
      if (*p == 'T' || *p == 't') {
        in_time = true;
        ++p;
        continue;
      }
      const double k = std::strtod(p, &end);
      if (end == p || !std::isfinite(k) || k < 0) return std::nullopt;
      const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(*end)));
      double unit = 0;
      if (!in_time && u == 'D') unit = 86400;
      else if (in_time && u == 'H') unit = 3600;
      else if (in_time && u == 'M') unit = 60;
      else if (in_time && u == 'S') unit = 1;
      else return std::nullopt;
      total += k * unit;
      any = true;
      p = end + 1;
    }
    if (!any) return std::nullopt;
    return total;
  }
  // HH:MM:SS[.frac]
  double parts[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(*p))) return std::nullopt;
    parts[i] = std::strtod(p, &end);
    p = end;
    if (i < 2) {
      if (*p != ':') return std::nullopt;
      ++p;
    }
  }
  if (*p != '\0' || parts[1] >= 60 || parts[2] >= 60) return std::nullopt;
  return parts[0] * 3600 + parts[1] * 60 + parts[2];
}

class Reader {
 public:
  explicit Reader(DiagnosticList& d) : d_(d) {}

  bool project(Project& p) {
    const XmlElement& root = p.root;
    if (root.name != "project") {
      d_.error(root.pos, "expected a PLCopen <project> root element, found <" + root.name + ">");
      return false;
    }
    p.ns = attr(root, "xmlns");
    bool known = false;
    for (const char* ns : kNamespaces) known = known || p.ns == ns;
    if (!known) {
      d_.error(root.pos, "<project> namespace '" + p.ns +
                             "' is not PLCopen TC6 (expected http://www.plcopen.org/xml/tc6_0201, "
                             "tc6_0200 or tc6.xsd)");
      return false;
    }
    for (const XmlElement& c : root.children) {
      if (c.name == "types") {
        types(c, p);
      } else if (c.name == "instances") {
        for (const XmlElement& cs : c.children) {
          if (cs.name != "configurations") continue;
          for (const XmlElement& cf : cs.children) {
            if (cf.name == "configuration") p.configurations.push_back(configuration(cf));
          }
        }
      }
      if (c.name == "fileHeader") {
        p.company = attr(c, "companyName");
        p.product = attr(c, "productName");
      }
      // contentHeader, addData: descriptive only.
    }
    // CODESYS V3 keeps an application's POUs in its resource's addData.
    for (Pou& pou : vendor_pous_) p.pous.push_back(std::move(pou));
    for (size_t i = 0; i < p.pous.size(); ++i) {
      for (size_t j = 0; j < i; ++j) {
        if (iequals(p.pous[i].name, p.pous[j].name))
          d_.error(p.pous[i].pos, "POU '" + p.pous[i].name + "' is defined twice (also line " +
                                      std::to_string(p.pous[j].pos.line) + ")");
      }
    }
    return !d_.has_errors();
  }

 private:
  void types(const XmlElement& t, Project& p) {
    for (const XmlElement& c : t.children) {
      if (c.name == "dataTypes") {
        for (const XmlElement& dt : c.children) {
          if (dt.name == "dataType") data_type(dt, p);
        }
      } else if (c.name == "pous") {
        for (const XmlElement& pe : c.children) {
          if (pe.name == "pou") p.pous.push_back(pou(pe));
        }
      }
    }
    for (size_t i = 0; i < p.data_types.size(); ++i) {
      const DataType& dt = p.data_types[i];
      for (size_t j = 0; j < i; ++j) {
        if (iequals(dt.name, p.data_types[j].name))
          d_.error(dt.pos, "data type '" + dt.name + "' is defined twice (also line " +
                               std::to_string(p.data_types[j].pos.line) + ")");
      }
      if (elementary_type(dt.name) || iec::find_iec(dt.name))
        d_.error(dt.pos, "data type '" + dt.name + "' has the name of a standard type or block");
    }
  }

  // <dataType name="..."><baseType>(derived | elementary | enum | struct |
  // array | subrange)</baseType>[<initialValue>]</dataType>
  void data_type(const XmlElement& e, Project& p) {
    DataType t;
    t.name = attr(e, "name");
    t.pos = e.pos;
    if (t.name.empty()) {
      d_.error(e.pos, "<dataType> without a name");
      return;
    }
    const XmlElement* bt = e.child("baseType");
    const XmlElement* body = nullptr;
    if (bt) {
      for (const XmlElement& c : bt->children) {
        if (c.name != "addData" && c.name != "documentation") {
          body = &c;
          break;
        }
      }
    }
    if (!body) {
      d_.error(e.pos, "<dataType name=\"" + t.name + "\"> has no <baseType>");
      return;
    }
    if (body->name == "enum") {
      t.kind = DataType::Kind::kEnum;
      if (const XmlElement* vs = body->child("values")) {
        for (const XmlElement& v : vs->children) {
          if (v.name != "value") continue;
          const std::string n = attr(v, "name");
          if (n.empty()) {
            d_.error(v.pos, "an enumeration <value> without a name");
            continue;
          }
          // A given value (CODESYS writes them), else one past the previous.
          int number = t.numbers.empty() ? 0 : t.numbers.back() + 1;
          if (const std::string given = attr(v, "value"); !given.empty()) {
            const auto k = parse_literal(given);
            if (!k || *k != std::floor(*k) || std::fabs(*k) > 2147483647.0) {
              d_.error(v.pos, "enumeration value '" + n + "': '" + given + "' is not a whole number of a DINT");
              continue;
            }
            number = static_cast<int>(*k);
          }
          t.values.push_back(n);
          t.numbers.push_back(number);
        }
      }
      if (t.values.empty()) d_.error(body->pos, "enumeration '" + t.name + "' has no values");
    } else if (body->name == "struct") {
      t.kind = DataType::Kind::kStruct;
      variables(*body, VarSection::kLocal, t.members);
      for (const Variable& m : t.members) {
        if (!m.address.empty()) d_.error(m.pos, "structure member '" + m.name + "' cannot be located");
      }
      if (t.members.empty()) d_.error(body->pos, "structure '" + t.name + "' has no members");
    } else if (body->name == "array") {
      t.kind = DataType::Kind::kArray;
      t.array = array_type(*body);
      if (!t.array) return;
    } else {
      auto r = type_of(*bt);  // derived, elementary or a subrange: an alias
      if (!r) return;
      t.alias = *r;
    }
    if (const XmlElement* iv = e.child("initialValue")) {
      if (const XmlElement* sv = iv->child("simpleValue")) t.initial = attr(*sv, "value");
      else t.initial_xml = iv;
    }
    p.data_types.push_back(std::move(t));
  }

  // <array><dimension lower= upper=/>...<baseType>T</baseType></array>
  std::shared_ptr<const ArrayType> array_type(const XmlElement& a) {
    auto r = std::make_shared<ArrayType>();
    for (const XmlElement& d : a.children) {
      if (d.name != "dimension") continue;
      const auto lo = parse_literal(attr(d, "lower")), hi = parse_literal(attr(d, "upper"));
      if (!lo || !hi || *lo != std::floor(*lo) || *hi != std::floor(*hi)) {
        d_.error(d.pos, "array bounds must be integer literals (lower=\"" + attr(d, "lower") + "\" upper=\"" +
                            attr(d, "upper") + "\")");
        return nullptr;
      }
      if (*hi < *lo) {
        d_.error(d.pos, "array dimension " + attr(d, "lower") + ".." + attr(d, "upper") + " is empty");
        return nullptr;
      }
      if (std::abs(*lo) > 1e9 || std::abs(*hi) > 1e9 ||
          (*hi - *lo + 1) * static_cast<double>(r->dims.empty() ? 1 : r->size()) > static_cast<double>(kMaxArrayElements)) {
        d_.error(d.pos, "array of more than " + std::to_string(kMaxArrayElements) +
                            " elements: rtplc holds each element in a block of its own");
        return nullptr;
      }
      r->dims.emplace_back(static_cast<int64_t>(*lo), static_cast<int64_t>(*hi));
    }
    if (r->dims.empty()) {
      d_.error(a.pos, "<array> without a <dimension>");
      return nullptr;
    }
    const XmlElement* bt = a.child("baseType");
    if (!bt) {
      d_.error(a.pos, "<array> without a <baseType>");
      return nullptr;
    }
    auto el = type_of(*bt);
    if (!el) return nullptr;
    r->element = *el;
    return r;
  }

  Pou pou(const XmlElement& e) {
    Pou p;
    p.name = attr(e, "name");
    p.pos = e.pos;
    if (p.name.empty()) d_.error(e.pos, "<pou> without a name");
    const std::string t = attr(e, "pouType");
    if (t == "program") p.type = PouType::kProgram;
    else if (t == "functionBlock") p.type = PouType::kFunctionBlock;
    else if (t == "function") p.type = PouType::kFunction;
    else d_.error(e.pos, "<pou name=\"" + p.name + "\">: pouType '" + t +
                             "' is not program, functionBlock or function");
    bool had_body = false;
    for (const XmlElement& c : e.children) {
      if (c.name == "interface") {
        interface(c, p);
      } else if (c.name == "body") {
        if (had_body) {
          d_.error(c.pos, "<pou name=\"" + p.name + "\">: a second <body> is not supported");
          continue;
        }
        had_body = true;
        body(c, p.body);
      } else if (c.name == "actions" || c.name == "transitions") {
        const bool act = c.name == "actions";
        for (const XmlElement& a : c.children) {
          if (a.name != (act ? "action" : "transition")) continue;
          NamedBody nb;
          nb.name = attr(a, "name");
          nb.pos = a.pos;
          const XmlElement* b = a.child("body");
          if (nb.name.empty() || !b) {
            d_.error(a.pos, "<" + a.name + "> needs a name and a <body>");
            continue;
          }
          body(*b, nb.body);
          (act ? p.actions : p.transitions).push_back(std::move(nb));
        }
      }
    }
    if (!had_body) d_.error(e.pos, "<pou name=\"" + p.name + "\"> has no <body>");
    return p;
  }

  std::optional<TypeRef> type_of(const XmlElement& te) {
    for (const XmlElement& c : te.children) {
      if (c.name == "addData" || c.name == "documentation") continue;
      if (c.name == "derived") {
        TypeRef r;
        r.base = BaseType::kDerived;
        r.derived = attr(c, "name");
        if (r.derived.empty()) {
          d_.error(c.pos, "<derived> without a name");
          return std::nullopt;
        }
        if (auto b = elementary_type(r.derived)) {
          r.base = *b;
          r.hmi = is_hmi_type(r.derived);
          r.derived.clear();
        }
        return r;
      }
      if (auto b = elementary_type(c.name)) return TypeRef{*b, {}, nullptr};
      if (c.name == "array") {
        auto a = array_type(c);
        if (!a) return std::nullopt;
        TypeRef r;
        r.base = BaseType::kDerived;
        r.array = a;
        return r;
      }
      if (c.name == "subrangeSigned" || c.name == "subrangeUnsigned") {
        // The range is not checked at run time: the base type's wrap applies.
        if (const XmlElement* b = c.child("baseType")) return type_of(*b);
      }
      if (c.name == "string" || c.name == "wstring") {
        TypeRef r;
        r.base = c.name == "string" ? BaseType::kString : BaseType::kWString;
        const std::string len = attr(c, "length");
        if (!len.empty()) {
          const long n = std::strtol(len.c_str(), nullptr, 10);
          if (n < 1 || n > static_cast<long>(kMaxStringLength)) {
            d_.error(c.pos, "STRING of length " + len + ": 1 to " + std::to_string(kMaxStringLength));
            return std::nullopt;
          }
          r.string_len = static_cast<uint32_t>(n);
        }
        return r;
      }
      d_.error(c.pos, "type <" + c.name + "> is not supported here (elementary types, arrays, subranges, "
                                          "and data types and function blocks by name are)");
      return std::nullopt;
    }
    d_.error(te.pos, "<type> names no type");
    return std::nullopt;
  }

  void variables(const XmlElement& sec, VarSection s, std::vector<Variable>& out) {
    const bool constant = attr(sec, "constant") == "true";
    if (attr(sec, "retain") == "true" || attr(sec, "persistent") == "true") {
      // Retention is the runtime's (docs/runtime.md); accepted, not per variable.
    }
    for (const XmlElement& v : sec.children) {
      if (v.name != "variable") continue;
      Variable var;
      var.name = attr(v, "name");
      var.section = s;
      var.address = attr(v, "address");
      var.constant = constant;
      var.pos = v.pos;
      if (var.name.empty()) d_.error(v.pos, "<variable> without a name");
      bool typed = false;
      for (const XmlElement& c : v.children) {
        if (c.name == "type") {
          if (auto t = type_of(c)) var.type = *t;
          typed = true;
        } else if (c.name == "initialValue") {
          if (const XmlElement* sv = c.child("simpleValue")) var.initial = attr(*sv, "value");
          else var.initial_xml = &c;  // arrayValue / structValue, read with the type
        }
      }
      if (!typed) d_.error(v.pos, "variable '" + var.name + "' has no <type>");
      for (const Variable& o : out) {
        if (iequals(o.name, var.name))
          d_.error(v.pos, "variable '" + var.name + "' is declared twice (also line " +
                              std::to_string(o.pos.line) + ")");
      }
      out.push_back(std::move(var));
    }
  }

  void interface(const XmlElement& e, Pou& p) {
    for (const XmlElement& c : e.children) {
      if (c.name == "returnType") {
        p.return_type = type_of(c);
      } else if (c.name == "inputVars") {
        variables(c, VarSection::kInput, p.vars);
      } else if (c.name == "outputVars") {
        variables(c, VarSection::kOutput, p.vars);
      } else if (c.name == "inOutVars") {
        variables(c, VarSection::kInOut, p.vars);
      } else if (c.name == "localVars") {
        variables(c, VarSection::kLocal, p.vars);
      } else if (c.name == "tempVars") {
        variables(c, VarSection::kTemp, p.vars);
      } else if (c.name == "externalVars") {
        variables(c, VarSection::kExternal, p.vars);
      } else if (c.name == "globalVars") {
        variables(c, VarSection::kGlobal, p.vars);
      } else if (c.name == "accessVars") {
        if (!c.children.empty()) d_.error(c.pos, "<accessVars> are not supported");
      }
    }
    if (p.type == PouType::kFunction && !p.return_type)
      d_.error(e.pos, "function '" + p.name + "' has no <returnType>");
  }

  void body(const XmlElement& e, Body& b) {
    b.pos = e.pos;
    for (const XmlElement& c : e.children) {
      if (c.name == "addData" || c.name == "documentation") continue;
      if (c.name == "FBD") b.language = BodyLanguage::kFbd;
      else if (c.name == "LD") b.language = BodyLanguage::kLd;
      else if (c.name == "SFC") b.language = BodyLanguage::kSfc;
      else if (c.name == "ST") b.language = BodyLanguage::kSt;
      else if (c.name == "IL") b.language = BodyLanguage::kIl;
      else {
        d_.error(c.pos, "body language <" + c.name + "> is not PLCopen (FBD, LD, SFC, ST, IL)");
        return;
      }
      b.pos = c.pos;
      if (b.language == BodyLanguage::kSt || b.language == BodyLanguage::kIl) {
        // <ST><xhtml:p><![CDATA[...]]></xhtml:p></ST> (OpenPLC, Beremiz),
        // <ST><xhtml xmlns="...">...</xhtml></ST> (CODESYS), or bare text.
        const XmlElement* holder = &c;
        for (const XmlElement& t : c.children) {
          if (t.name == "p" || t.name == "xhtml") holder = &t;
        }
        b.text = holder;
        b.source = holder->text;
      } else {
        b.graph = &c;
      }
      return;
    }
    d_.error(e.pos, "<body> holds no FBD, LD, SFC, ST or IL");
  }

  Configuration configuration(const XmlElement& e) {
    Configuration cf;
    cf.name = attr(e, "name");
    cf.pos = e.pos;
    for (const XmlElement& c : e.children) {
      if (c.name == "globalVars") variables(c, VarSection::kGlobal, cf.globals);
      else if (c.name == "resource") cf.resources.push_back(resource(c));
    }
    return cf;
  }

  PouInstance instance(const XmlElement& e) {
    PouInstance pi;
    pi.name = attr(e, "name");
    pi.type_name = attr(e, "typeName");
    if (pi.type_name.empty()) pi.type_name = attr(e, "type");  // tc6.xsd drafts
    pi.pos = e.pos;
    if (pi.name.empty() || pi.type_name.empty())
      d_.error(e.pos, "<pouInstance> needs a name and a typeName");
    return pi;
  }

  Resource resource(const XmlElement& e) {
    Resource r;
    r.name = attr(e, "name");
    r.pos = e.pos;
    for (const XmlElement& c : e.children) {
      if (c.name == "globalVars") {
        variables(c, VarSection::kGlobal, r.globals);
      } else if (c.name == "pouInstance") {
        r.unassigned.push_back(instance(c));
      } else if (c.name == "addData") {
        // CODESYS V3: <data name=".../plcopenxml/pou"><pou>, and global
        // variable lists as <data name=".../plcopenxml/globalvars"><globalVars>.
        for (const XmlElement& d : c.children) {
          if (d.name != "data") continue;
          const std::string n = attr(d, "name");
          const auto ends = [&](std::string_view tail) {
            return n.size() >= tail.size() && n.compare(n.size() - tail.size(), tail.size(), tail) == 0;
          };
          for (const XmlElement& x : d.children) {
            if (ends("/pou") && x.name == "pou") vendor_pous_.push_back(pou(x));
            else if (ends("/globalvars") && x.name == "globalVars") variables(x, VarSection::kGlobal, r.globals);
          }
        }
      } else if (c.name == "task") {
        Task t;
        t.name = attr(c, "name");
        t.pos = c.pos;
        const std::string iv = attr(c, "interval");
        if (!iv.empty()) {
          auto v = parse_interval(iv);
          if (!v || *v <= 0) {
            d_.error(c.pos, "task '" + t.name + "': interval '" + iv +
                                "' is not a positive time (T#20ms, PT0.02S or 00:00:00.020)");
          } else {
            t.interval = *v;
          }
        }
        const std::string pr = attr(c, "priority");
        if (!pr.empty()) {
          char* end = nullptr;
          const long v = std::strtol(pr.c_str(), &end, 10);
          if (*end != '\0' || v < 0 || v > 99) {
            d_.error(c.pos, "task '" + t.name + "': priority '" + pr + "' is not 0..99");
          } else {
            t.priority = static_cast<int>(v);
          }
        }
        t.single = attr(c, "single");
        for (const XmlElement& pi : c.children) {
          if (pi.name == "pouInstance") t.instances.push_back(instance(pi));
        }
        r.tasks.push_back(std::move(t));
      }
    }
    return r;
  }

  DiagnosticList& d_;
  std::vector<Pou> vendor_pous_;  // POUs found in a resource's addData
};

// Digits of `s` in base `base`, with IEC underscores; false if none or a bad digit.
bool parse_integer(std::string_view s, int base, double* out) {
  double v = 0;
  bool any = false;
  for (char c : s) {
    if (c == '_') continue;
    int dgt;
    if (c >= '0' && c <= '9') dgt = c - '0';
    else if (c >= 'a' && c <= 'f') dgt = c - 'a' + 10;
    else if (c >= 'A' && c <= 'F') dgt = c - 'A' + 10;
    else return false;
    if (dgt >= base) return false;
    v = v * base + dgt;
    any = true;
  }
  *out = v;
  return any;
}

// Whole digits of s[i..] up to `max` of them, at least one; advances i.
std::optional<int> digits(std::string_view s, size_t& i, size_t max) {
  const size_t b = i;
  int v = 0;
  while (i < s.size() && i - b < max && s[i] >= '0' && s[i] <= '9') v = v * 10 + (s[i++] - '0');
  if (i == b) return std::nullopt;
  return v;
}

// Days from 1970-01-01 to y-m-d of the proleptic Gregorian calendar (the
// civil-days formula: years counted from March, so the leap day ends a year).
int64_t days_since_1970(int y, int m, int d) {
  y -= m <= 2 ? 1 : 0;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const int64_t yoe = y - era * 400;
  const int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

// 2024-01-15: seconds since 1970-01-01 at its midnight. Years 1970..2255 (a
// DT's microseconds stay exact in a double until 2255; DT_TO_TOD counts from
// 1970).
std::optional<double> parse_date_part(std::string_view s, size_t& i) {
  const auto y = digits(s, i, 4);
  if (!y || i >= s.size() || s[i++] != '-') return std::nullopt;
  const auto m = digits(s, i, 2);
  if (!m || i >= s.size() || s[i++] != '-') return std::nullopt;
  const auto d = digits(s, i, 2);
  if (!d || *y < 1970 || *y > 2255 || *m < 1 || *m > 12 || *d < 1) return std::nullopt;
  const bool leap = (*y % 4 == 0 && *y % 100 != 0) || *y % 400 == 0;
  static constexpr int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  if (*d > kDays[*m - 1] + (*m == 2 && leap ? 1 : 0)) return std::nullopt;
  return static_cast<double>(days_since_1970(*y, *m, *d) * 86400);
}

// 12:30:15.25 (seconds optional, with a fraction): seconds since midnight.
std::optional<double> parse_tod_part(std::string_view s, size_t& i) {
  const auto h = digits(s, i, 2);
  if (!h || i >= s.size() || s[i++] != ':') return std::nullopt;
  const auto m = digits(s, i, 2);
  if (!m || *h > 23 || *m > 59) return std::nullopt;
  double sec = 0;
  if (i < s.size() && s[i] == ':') {
    ++i;
    const size_t b = i;
    const auto whole = digits(s, i, 2);
    if (!whole || *whole > 59) return std::nullopt;
    if (i < s.size() && s[i] == '.') {
      ++i;
      if (!digits(s, i, 9)) return std::nullopt;
    }
    sec = std::strtod(std::string(s.substr(b, i - b)).c_str(), nullptr);
  }
  return *h * 3600.0 + *m * 60.0 + sec;
}

// The text after D#, TOD# or DT#, whole, else nothing.
std::optional<double> parse_date_literal(iec::IecType t, std::string_view s) {
  size_t i = 0;
  std::optional<double> v;
  if (t == iec::IecType::kDate) {
    v = parse_date_part(s, i);
  } else if (t == iec::IecType::kTod) {
    v = parse_tod_part(s, i);
  } else {
    v = parse_date_part(s, i);
    if (v && i < s.size() && s[i] == '-') {
      ++i;
      const auto tod = parse_tod_part(s, i);
      v = tod ? std::optional<double>(*v + *tod) : std::nullopt;
    } else {
      v = std::nullopt;
    }
  }
  if (!v || i != s.size()) return std::nullopt;
  return int_math::snap_to(*v, iec::time_grid(t));
}

std::optional<double> parse_time(std::string_view s) {
  // 1h2m3s4ms, 1.5s, 20ms, with optional underscores; units d h m s ms us ns.
  bool neg = false;
  if (!s.empty() && s[0] == '-') {
    neg = true;
    s.remove_prefix(1);
  }
  if (s.empty()) return std::nullopt;
  double total = 0;
  size_t i = 0;
  while (i < s.size()) {
    const size_t b = i;
    while (i < s.size() && ((s[i] >= '0' && s[i] <= '9') || s[i] == '.' || s[i] == '_')) ++i;
    if (i == b) return std::nullopt;
    std::string num;
    for (size_t k = b; k < i; ++k) {
      if (s[k] != '_') num += s[k];
    }
    char* end = nullptr;
    const double v = std::strtod(num.c_str(), &end);
    if (*end != '\0') return std::nullopt;
    const size_t ub = i;
    while (i < s.size() && std::isalpha(static_cast<unsigned char>(s[i]))) ++i;
    const std::string unit = upper(s.substr(ub, i - ub));
    double f;
    if (unit == "D") f = 86400;
    else if (unit == "H") f = 3600;
    else if (unit == "M") f = 60;
    else if (unit == "S") f = 1;
    else if (unit == "MS") f = 1e-3;
    else if (unit == "US") f = 1e-6;
    else if (unit == "NS") f = 1e-9;
    else return std::nullopt;
    total += v * f;
    while (i < s.size() && s[i] == '_') ++i;
  }
  return neg ? -total : total;
}

}  // namespace

std::optional<iec::IecType> date_literal_type(std::string_view prefix) {
  const std::string p = upper(prefix);
  if (p == "D" || p == "DATE") return iec::IecType::kDate;
  if (p == "TOD" || p == "TIME_OF_DAY") return iec::IecType::kTod;
  if (p == "DT" || p == "DATE_AND_TIME") return iec::IecType::kDt;
  return std::nullopt;
}

std::optional<double> parse_literal(std::string_view text, bool* is_bool, bool* is_time) {
  if (is_bool) *is_bool = false;
  if (is_time) *is_time = false;
  std::string_view s = text;
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  if (s.empty()) return std::nullopt;
  const size_t hash = s.find('#');
  if (hash != std::string_view::npos) {
    const std::string prefix = upper(s.substr(0, hash));
    std::string_view rest = s.substr(hash + 1);
    if (prefix == "T" || prefix == "TIME" || prefix == "LTIME" || prefix == "LT") {
      if (is_time) *is_time = true;
      return parse_time(rest);
    }
    if (const auto dt = date_literal_type(prefix)) {
      if (is_time) *is_time = true;
      return parse_date_literal(*dt, rest);
    }
    if (prefix == "BOOL") {
      if (rest == "1" || iequals(rest, "TRUE")) {
        if (is_bool) *is_bool = true;
        return 1.0;
      }
      if (rest == "0" || iequals(rest, "FALSE")) {
        if (is_bool) *is_bool = true;
        return 0.0;
      }
      return std::nullopt;
    }
    int base = 0;
    if (prefix == "16") base = 16;
    else if (prefix == "8") base = 8;
    else if (prefix == "2") base = 2;
    if (base) {
      double v = 0;
      if (!parse_integer(rest, base, &v)) return std::nullopt;
      return v;
    }
    if (elementary_type(prefix)) return parse_literal(rest, is_bool, is_time);
    return std::nullopt;
  }
  if (iequals(s, "TRUE")) {
    if (is_bool) *is_bool = true;
    return 1.0;
  }
  if (iequals(s, "FALSE")) {
    if (is_bool) *is_bool = true;
    return 0.0;
  }
  std::string num;
  for (char c : s) {
    if (c != '_') num += c;
  }
  if (num.empty() || !(std::isdigit(static_cast<unsigned char>(num[0])) || num[0] == '-' || num[0] == '+'))
    return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(num.c_str(), &end);
  if (*end != '\0' || !std::isfinite(v)) return std::nullopt;
  for (char c : num) {  // strtod also reads hex floats and "inf": IEC has neither
    if (c == 'x' || c == 'X' || c == 'n' || c == 'N' || c == 'i' || c == 'I') return std::nullopt;
  }
  return v;
}

std::optional<std::string> parse_string_literal(std::string_view t, std::string* error, bool* wide_out) {
  auto fail = [&](const std::string& m) -> std::optional<std::string> {
    if (error != nullptr) *error = m;
    return std::nullopt;
  };
  while (!t.empty() && std::isspace(static_cast<unsigned char>(t.front()))) t.remove_prefix(1);
  while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.remove_suffix(1);
  int typed = 0;  // 1 STRING#, 2 WSTRING#
  if (t.size() > 7 && iequals(t.substr(0, 7), "STRING#")) t.remove_prefix(7), typed = 1;
  else if (t.size() > 8 && iequals(t.substr(0, 8), "WSTRING#")) t.remove_prefix(8), typed = 2;
  const char q = t.empty() ? '\0' : t.front();
  const bool wide = q == '"';
  if ((typed == 1 && wide) || (typed == 2 && q == '\'')) {
    return fail(typed == 1 ? "STRING# takes '...' (\"...\" is a WSTRING)" : "WSTRING# takes \"...\" ('...' is a STRING)");
  }
  if (wide_out != nullptr) *wide_out = wide;
  if (t.size() < 2 || (q != '\'' && q != '"') || t.back() != q) return fail("not a string literal ('...' or \"...\")");
  t = t.substr(1, t.size() - 2);
  std::string out;
  size_t units = 0;  // characters: bytes of a STRING, UTF-16 code units of a WSTRING
  const size_t hex = wide ? 4 : 2;
  for (size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == q) return fail(std::string("a quote inside a string is written $") + q);
    if (c != '$') {
      out += c;
      units += wide ? 0 : 1;  // (a WSTRING's are counted from its UTF-8 below)
      continue;
    }
    if (i + 1 >= t.size()) return fail("a string ends in a lone $ (write $$ for a dollar sign)");
    const char e = static_cast<char>(std::toupper(static_cast<unsigned char>(t[++i])));
    units += wide ? 0 : 1;
    switch (e) {
      case '$': out += '$'; break;
      case '\'': out += '\''; break;
      case '"': out += '"'; break;
      case 'L': case 'N': out += '\n'; break;
      case 'P': out += '\f'; break;
      case 'R': out += '\r'; break;
      case 'T': out += '\t'; break;
      default: {
        bool ok = i + hex <= t.size();
        for (size_t k = 0; k < hex && ok; ++k) ok = std::isxdigit(static_cast<unsigned char>(t[i + k])) != 0;
        if (!ok) {
          return fail(std::string("unknown escape $") + t[i] + " in a string ($$ $' $\" $L $N $P $R $T or $ and " +
                      (wide ? "four" : "two") + " hex digits)");
        }
        const auto code = static_cast<uint32_t>(std::stoul(std::string(t.substr(i, hex)), nullptr, 16));
        if (wide) append_utf8(out, code);
        else out += static_cast<char>(code);
        i += hex - 1;
      }
    }
  }
  if (wide) units = utf16_units(out).size();
  if (units > kMaxStringLength) {
    return fail("a string of " + std::to_string(units) + " characters: at most " + std::to_string(kMaxStringLength));
  }
  return out;
}

bool is_hmi_type(std::string_view name) {
  return name.size() > 4 && (name.substr(0, 4) == "HMI_" || name.substr(0, 4) == "hmi_");
}

std::optional<BaseType> elementary_type(std::string_view name) {
  // Beremiz SVGHMI's HMI_BOOL, HMI_INT, HMI_REAL...: their elementary type,
  // exposed to an HMI (docs/st.md, "HMI variables").
  if (is_hmi_type(name)) name.remove_prefix(4);
  if (iequals(name, "STRING")) return BaseType::kString;
  if (iequals(name, "WSTRING")) return BaseType::kWString;
  const iec::IecTypeInfo* t = iec::find_iec_type(name);
  if (t == nullptr) return std::nullopt;
  return static_cast<BaseType>(t->type);  // the same order (project.h)
}

std::string type_name(const TypeRef& t) {
  if (t.base == BaseType::kDerived) return t.derived;
  if (t.base == BaseType::kString || t.base == BaseType::kWString) {
    const std::string w = t.base == BaseType::kString ? "STRING" : "WSTRING";
    return t.string_len ? w + "[" + std::to_string(t.string_len) + "]" : w;
  }
  return iec::type_info(iec_type(t.base)).name;
}

const char* section_name(VarSection s) {
  switch (s) {
    case VarSection::kInput: return "inputVars";
    case VarSection::kOutput: return "outputVars";
    case VarSection::kInOut: return "inOutVars";
    case VarSection::kLocal: return "localVars";
    case VarSection::kTemp: return "tempVars";
    case VarSection::kExternal: return "externalVars";
    case VarSection::kGlobal: return "globalVars";
  }
  return "?";
}

const char* language_name(BodyLanguage l) {
  switch (l) {
    case BodyLanguage::kNone: return "none";
    case BodyLanguage::kFbd: return "FBD";
    case BodyLanguage::kLd: return "LD";
    case BodyLanguage::kSt: return "ST";
    case BodyLanguage::kIl: return "IL";
    case BodyLanguage::kSfc: return "SFC";
  }
  return "?";
}

const Variable* Pou::var(std::string_view n) const {
  for (const Variable& v : vars) {
    if (iequals(v.name, n)) return &v;
  }
  return nullptr;
}

const DataType* Project::data_type(std::string_view n) const {
  for (const DataType& t : data_types) {
    if (iequals(t.name, n)) return &t;
  }
  return nullptr;
}

std::optional<int> Project::enum_value(std::string_view n) const {
  const size_t hash = n.find('#');
  const std::string_view type = hash == std::string_view::npos ? std::string_view() : n.substr(0, hash);
  const std::string_view value = hash == std::string_view::npos ? n : n.substr(hash + 1);
  for (const DataType& t : data_types) {
    if (t.kind != DataType::Kind::kEnum || (!type.empty() && !iequals(t.name, type))) continue;
    for (size_t k = 0; k < t.values.size(); ++k) {
      if (iequals(t.values[k], value)) return k < t.numbers.size() ? t.numbers[k] : static_cast<int>(k);
    }
  }
  return std::nullopt;
}

const Pou* Project::pou(std::string_view n) const {
  for (const Pou& p : pous) {
    if (iequals(p.name, n)) return &p;
  }
  return nullptr;
}

std::optional<Project> read_project(std::string_view text, DiagnosticList& diags) {
  std::optional<XmlElement> root = parse_xml(text, diags);
  if (!root) return std::nullopt;
  Project p;
  p.root = std::move(*root);
  Reader r(diags);
  if (!r.project(p)) return std::nullopt;
  return p;
}

}  // namespace rtplc::lang::plcopen
