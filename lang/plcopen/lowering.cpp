// Scopes and variables, bodies, and the end of the cycle (see lowering.h);
// function calls and FB instances are in calls.cpp.
#include "lang/plcopen/lowering.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

#include "blocks/int_math.h"
#include "blocks/image.h"
#include "blocks/registry.h"

namespace rtplc::lang::plcopen {

// A word size's rank: W 1, D 2, L 3, B 4 (X 0). It numbers the analog
// groups (processor p<rank>, W's p0), the memory devices (d<rank>) and the
// hierarchical processors (100 + 25 * rank).
static uint32_t size_rank(char size) {
  return size == 'W' ? 1 : size == 'D' ? 2 : size == 'L' ? 3 : size == 'B' ? 4 : 0;
}

std::optional<Location> parse_location(const std::string& a, std::string* error) {
  Location l;
  auto bad = [&](const std::string& why) -> std::optional<Location> {
    *error = "address '" + a + "' " + why;
    return std::nullopt;
  };
  if (a.size() < 3 || a[0] != '%') return bad("is not a located address such as %IX0.0");
  l.area = static_cast<char>(std::toupper(static_cast<unsigned char>(a[1])));
  if (l.area != 'I' && l.area != 'Q' && l.area != 'M') return bad("has an area other than I, Q or M");
  size_t i = 2;
  l.size = 'X';
  if (std::isalpha(static_cast<unsigned char>(a[i]))) {
    l.size = static_cast<char>(std::toupper(static_cast<unsigned char>(a[i])));
    ++i;
  }
  if (l.size != 'X' && l.size != 'B' && l.size != 'W' && l.size != 'D' && l.size != 'L')
    return bad("has size '" + std::string(1, l.size) + "' (rtplc maps X, B, W, D and L)");
  std::vector<uint32_t> parts;
  uint64_t v = 0;
  bool any = false;
  for (; i <= a.size(); ++i) {
    if (i == a.size() || a[i] == '.') {
      if (!any) return bad("is malformed");
      parts.push_back(static_cast<uint32_t>(v));
      v = 0;
      any = false;
      continue;
    }
    if (!std::isdigit(static_cast<unsigned char>(a[i]))) return bad("is malformed");
    v = v * 10 + static_cast<uint64_t>(a[i] - '0');
    if (v > 65535) return bad("has a number above 65535");
    any = true;
  }
  if (parts.size() >= (l.size == 'X' ? 3u : 2u)) {
    // Beremiz's hierarchical addresses (%IX0.1.0.0, %IW0.0.2.0: an
    // extension's location, then the item in it): a channel of processor
    // 100 + first level (X), 125 + (W), 150 + (D), 175 + (L), 200 + (B),
    // one address per form, however many levels (docs/plcopen.md, "Located
    // variables"):   a.b       -> d255, c b
    //                a.b.c     -> d b, c c          (b <= 254, c <= 255)
    //                a.b.c.d   -> d b, c 256 + 256c + d   (c <= 254)
    // A driver binds it by that address.
    if (l.area == 'M') return bad("has several levels; a memory address has one (%MW2) or byte.bit (%MX0.3)");
    if (parts.size() > 4) return bad("has more than four levels (rtplc maps up to four: %IX0.1.2.3)");
    if (parts[0] > 24) return bad("has a first level above 24 (rtplc maps 0 to 24)");
    if (parts.size() > 2 && parts[1] > 254) return bad("has a second level above 254 (rtplc maps 0 to 254 here)");
    if (parts.size() == 3 && parts[2] > 255) return bad("has a third level above 255 (rtplc maps 0 to 255)");
    if (parts.size() == 4 && (parts[2] > 254 || parts[3] > 255)) {
      return bad("has a third level above 254 or a fourth above 255 (rtplc maps those)");
    }
    l.p = 100 + 25 * size_rank(l.size) + parts[0];
    l.d = parts.size() == 2 ? 255 : parts[1];
    l.c = parts.size() == 2 ? parts[1] : parts.size() == 3 ? parts[2] : 256 + 256 * parts[2] + parts[3];
    return l;
  }
  if (l.size == 'X') {
    if (parts.size() == 1) {
      // A single-level bit address (%IX12, MatIEC's tests): bit 12 counted
      // from bit 0 of byte 0, so %IX12 is %IX1.4.
      parts = {parts[0] / 8, parts[0] % 8};
    }
    if (parts.size() != 2) return bad("needs byte.bit, e.g. %IX0.3");
    if (parts[0] > 255) return bad("has a byte above 255");
    if (parts[1] > 7) return bad("has a bit above 7");
    l.p = 1;
    l.d = parts[0];
    l.c = parts[1];
    if (l.area == 'M') {  // set-points: d0, channel byte*8+bit
      l.d = 0;
      l.c = parts[0] * 8 + parts[1];
    }
  } else {
    if (parts.size() != 1) return bad("needs one number, e.g. %IW2");
    const uint32_t rank = size_rank(l.size);
    l.p = rank == 1 ? 0 : rank;  // W is p0 (p1 holds the bits)
    l.d = 0;
    l.c = parts[0];
    if (l.area == 'M') l.d = rank;
  }
  return l;
}

namespace {
std::string format_index(double k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", k);
  return buf;
}

}  // namespace

// "a[#1].x" as the user wrote it, near enough: "a[...].x".
std::string path_text(const std::string& path) {
  std::string r;
  for (size_t i = 0; i < path.size(); ++i) {
    if (path[i] == '[') {
      r += "[...]";
      i = path.find(']', i);
      if (i == std::string::npos) break;
    } else {
      r += path[i];
    }
  }
  return r;
}

Lowering::Lowering(const Project& p, CheckedProgram& out, DiagnosticList& d)
    : proj_(p), em_(out, d), d_(d), out_(out) {
  for (const Pou& pou : proj_.pous) collect_written(pou, written_);
}

// A channel block's address and label: the variable's location, and its
// name (an HMI variable's path, and its mark).
void Lowering::place_channel(FlatBlock& b, const Var& v) {
  b.p = static_cast<uint16_t>(v.loc->p);
  b.d = static_cast<uint16_t>(v.loc->d);
  b.c = v.loc->c;
  b.label = v.hmi ? v.path : v.decl->name;
  b.hmi = v.hmi;
}

void Lowering::emit_channel(Var& v) {
  // Inputs and set-points are read at the start of the cycle: emitted when
  // the scope is made, before any body reads them.
  const SourcePos pos = v.decl->pos;
  const size_t i = v.role == Var::Role::kInput ? em_.emit(v.digital ? "ddi" : "dai", v.path, pos, {})
                                               : em_.emit(v.digital ? "dsp" : "asp", v.path, pos, {});
  FlatBlock& b = em_.block(i);
  place_channel(b, v);
  if (v.role == Var::Role::kSetpoint && !v.decl->initial.empty()) {
    if (auto k = parse_literal(v.decl->initial)) b.init = v.digital ? (*k != 0 ? 1.0 : 0.0) : *k;
  }
}

const Variable& Lowering::resolved_decl(const Variable& decl) {
  if (decl.type.base != BaseType::kDerived || decl.type.array) return decl;
  const DataType* t = proj_.data_type(decl.type.derived);
  if (!t || (t->kind != DataType::Kind::kAlias && t->kind != DataType::Kind::kEnum)) return decl;
  auto r = std::make_unique<Variable>(decl);
  for (int hops = 0; t && t->kind == DataType::Kind::kAlias; ++hops) {
    if (hops > kMaxNesting) {
      d_.error(t->pos, "data type '" + t->name + "' is defined through itself");
      break;
    }
    if (r->initial.empty() && !r->initial_xml) {
      r->initial = t->initial;
      r->initial_xml = t->initial_xml;
    }
    r->type = t->alias;
    t = r->type.base == BaseType::kDerived && !r->type.array ? proj_.data_type(r->type.derived) : nullptr;
  }
  if (t && t->kind == DataType::Kind::kEnum) {
    // An enumeration is an INT holding the value's position (0, 1, ...).
    if (r->initial.empty()) r->initial = t->initial;
    // Without one, the first value (not 0, when the values are numbered).
    if (r->initial.empty() && !r->initial_xml && !t->values.empty()) r->initial = t->values[0];
    r->type = TypeRef{BaseType::kInt, {}, nullptr};
    if (!r->initial.empty()) {
      auto k = r->initial.find('#') != std::string::npos ? proj_.enum_value(r->initial)
                                                          : proj_.enum_value(t->name + "#" + r->initial);
      if (!k) {
        d_.error(decl.pos, "variable '" + decl.name + "': initial value '" + r->initial +
                               "' is not a value of enumeration " + t->name);
      } else {
        r->initial = std::to_string(*k);
      }
    }
  }
  const Variable& out = *r;
  owned_decls_.push_back(std::move(r));
  return out;
}

void Lowering::make_members(Var& v, const Variable& decl, const DataType& t, int depth, bool in_function) {
  v.role = Var::Role::kStruct;
  v.fb = std::make_unique<Scope>();
  v.fb->path = v.path;
  // <initialValue><structValue><value member="x">...: this variable's own
  // initial values, over the members' declared ones.
  std::map<std::string, const XmlElement*> given;
  const XmlElement* init = decl.initial_xml ? decl.initial_xml : t.initial_xml;
  if (const XmlElement* sv = init ? init->child("structValue") : nullptr) {
    for (const XmlElement& m : sv->children) {
      if (m.name != "value") continue;
      const XmlAttribute* a = m.attribute("member");
      const std::string name = a ? a->value : std::string();
      const bool known = std::any_of(t.members.begin(), t.members.end(),
                                     [&](const Variable& x) { return iequals(x.name, name); });
      if (!known) d_.error(m.pos, "structure " + t.name + " has no member '" + name + "'");
      given[upper(name)] = &m;
    }
  } else if (init) {
    d_.error(init->pos, "variable '" + decl.name + "' is a structure: its initial value must be a <structValue>");
  }
  for (const Variable& m : t.members) {
    auto md = std::make_unique<Variable>(m);
    md->name = decl.name + "." + m.name;
    md->section = decl.section;
    md->constant = decl.constant || m.constant;
    md->pos = decl.pos;
    if (auto it = given.find(upper(m.name)); it != given.end()) {
      md->initial.clear();
      md->initial_xml = nullptr;
      if (const XmlElement* simple = it->second->child("simpleValue")) {
        const XmlAttribute* a = simple->attribute("value");
        md->initial = a ? a->value : std::string();
      } else {
        md->initial_xml = it->second;
      }
    }
    const Variable& d = *md;
    owned_decls_.push_back(std::move(md));
    if (v.fb->vars.count(upper(m.name))) {
      d_.error(t.pos, "structure " + t.name + " has two members named '" + m.name + "'");
      continue;
    }
    auto mv = make_var(d, v.path + "." + m.name, depth, in_function);
    all_vars_.push_back(mv.get());
    v.fb->vars.emplace(upper(m.name), std::move(mv));
  }
}

void Lowering::make_elements(Var& v, const Variable& decl, std::shared_ptr<const ArrayType> a,
                             const XmlElement* init, int depth, bool in_function) {
  v.role = Var::Role::kArray;
  v.array = a;
  // <arrayValue><value [repetitionValue="n"]>...: the elements in order.
  std::vector<const XmlElement*> values;
  if (const XmlElement* av = init ? init->child("arrayValue") : nullptr) {
    for (const XmlElement& x : av->children) {
      if (x.name != "value") continue;
      long rep = 1;
      if (const XmlAttribute* r = x.attribute("repetitionValue")) {
        const auto k = parse_literal(r->value);
        if (!k || *k < 0 || *k != std::floor(*k) || *k > static_cast<double>(kMaxArrayElements)) {
          d_.error(x.pos, "repetitionValue '" + r->value + "' is not a count");
          return;
        }
        rep = static_cast<long>(*k);
      }
      for (long i = 0; i < rep; ++i) values.push_back(&x);
    }
    if (values.size() > a->size())
      d_.error(av->pos, "variable '" + decl.name + "' has " + std::to_string(a->size()) + " elements and " +
                            std::to_string(values.size()) + " initial values");
  } else if (init) {
    d_.error(init->pos, "variable '" + decl.name + "' is an array: its initial value must be an <arrayValue>");
  }
  const size_t n = a->size();
  elements_ += n;
  if (elements_ > kMaxArrayElements) {
    d_.error(decl.pos, "variable '" + decl.name + "': the task's arrays would hold more than " +
                           std::to_string(kMaxArrayElements) + " elements (each is a block of its own)");
    return;
  }
  for (size_t k = 0; k < n; ++k) {
    std::string idx;
    size_t rest = k, stride = n;
    for (const auto& [lo, hi] : a->dims) {
      stride /= static_cast<size_t>(hi - lo + 1);
      idx += (idx.empty() ? "" : ",") + std::to_string(lo + static_cast<int64_t>(rest / stride));
      rest %= stride;
    }
    auto ed = std::make_unique<Variable>(decl);
    ed->name = decl.name + "[" + idx + "]";
    ed->type = a->element;
    ed->address.clear();
    ed->initial.clear();
    ed->initial_xml = nullptr;
    if (k < values.size()) {
      if (const XmlElement* simple = values[k]->child("simpleValue")) {
        const XmlAttribute* at = simple->attribute("value");
        ed->initial = at ? at->value : std::string();
      } else {
        ed->initial_xml = values[k];
      }
    }
    const Variable& d = *ed;
    owned_decls_.push_back(std::move(ed));
    auto ev = make_var(d, v.path + "[" + idx + "]", depth, in_function);
    all_vars_.push_back(ev.get());
    v.elems.push_back(std::move(ev));
  }
}

std::unique_ptr<Var> Lowering::make_var(const Variable& decl0, const std::string& path, int depth,
                                        bool in_function) {
  const Variable& decl = resolved_decl(decl0);
  auto v = std::make_unique<Var>();
  v->decl = &decl;
  v->path = path;
  v->digital = decl.type.is_bool();
  v->integer = integer_type(decl.type.base);
  if (decl.type.base == BaseType::kString || decl.type.base == BaseType::kWString) {
    v->str = true;
    v->wide = decl.type.base == BaseType::kWString;
    v->cap = decl.type.string_len != 0 ? decl.type.string_len : default_string_length();
    if (!decl.address.empty() || decl.type.hmi) {
      d_.error(decl.pos, "variable '" + decl.name + "': a " + (v->wide ? "WSTRING " : "STRING ") +
                             (decl.type.hmi ? std::string("HMI variable") : "at " + decl.address) +
                             " is not supported yet: strings are the program's own (docs/st.md, \"Strings\")");
    }
    return v;
  }
  const DataType* user_type = decl.type.base == BaseType::kDerived && !decl.type.array
                                  ? proj_.data_type(decl.type.derived)
                                  : nullptr;
  if (decl.type.array || user_type) {
    if (!decl.address.empty()) {
      d_.error(decl.pos, "variable '" + decl.name + "': an array or structure cannot be located (" + decl.address +
                             "); locate its elements' values in variables of their own");
      return v;
    }
    if (depth > kMaxNesting) {
      d_.error(decl.pos, "variable '" + decl.name + "': data types nested deeper than " + std::to_string(kMaxNesting));
      return v;
    }
    if (decl.type.array) make_elements(*v, decl, decl.type.array, decl.initial_xml, depth + 1, in_function);
    else if (user_type->kind == DataType::Kind::kStruct) make_members(*v, decl, *user_type, depth + 1, in_function);
    else if (user_type->kind == DataType::Kind::kArray && user_type->array)
      make_elements(*v, decl, user_type->array, decl.initial_xml ? decl.initial_xml : user_type->initial_xml,
                    depth + 1, in_function);
    // Else an alias or enumeration resolved_decl() could not resolve (one
    // defined through itself): already reported there.
    return v;
  }
  if (decl.type.base == BaseType::kDerived) {
    if (decl.initial_xml || !decl.initial.empty()) {
      // Never dropped silently: the instance would start from its type's values.
      d_.error(decl.pos, "variable '" + decl.name + "': initial values of a function block instance are not "
                         "supported yet; give its inputs in its call");
      return v;
    }
    std::string up = upper(decl.type.derived);
    // CODESYS names the IEC blocks by their library: Standard.TON is TON.
    if (up.rfind("STANDARD.", 0) == 0 && iec::find_iec(up.substr(9))) up = up.substr(9);
    if (in_function) {
      d_.error(decl.pos, "variable '" + decl.name + "': a function cannot hold a function block instance");
    } else if (const iec::IecFunction* f = iec::find_iec(up); f && f->function_block) {
      v->role = Var::Role::kStdFb;
      v->std_fb.type = f->name;
      v->std_fb.iec = f;
    } else if (const Pou* fb = proj_.pou(decl.type.derived); fb && fb->type == PouType::kFunctionBlock) {
      if (depth >= kMaxNesting) {
        d_.error(decl.pos, "function block instances nested deeper than " + std::to_string(kMaxNesting) +
                               " (a block containing itself?)");
      } else {
        v->role = Var::Role::kUserFb;
        v->fb = make_scope(*fb, path, depth + 1);
      }
    } else {
      d_.error(decl.pos, "variable '" + decl.name + "' has type '" + decl.type.derived +
                             "', which is neither an elementary type, a standard function block "
                             "nor a function block of this project");
    }
    return v;
  }
  if (decl.type.hmi && decl.address.empty()) return hmi_var(std::move(v), in_function);
  if (!decl.address.empty()) {
    std::string err;
    v->loc = parse_location(decl.address, &err);
    if (!v->loc) {
      d_.error(decl.pos, "variable '" + decl.name + "': " + err);
    } else if (v->loc->area == 'I') {
      v->role = Var::Role::kInput;
    } else if (v->loc->area == 'M' &&
               std::find(written_.begin(), written_.end(), upper(decl.name)) == written_.end() &&
               std::find(written_.begin(), written_.end(), upper(decl.address)) == written_.end()) {
      v->role = Var::Role::kSetpoint;  // only read: the operator sets it
    }
    if (v->loc && (v->loc->size == 'X') != v->digital)
      d_.error(decl.pos, "variable '" + decl.name + "' is " + type_name(decl.type) + " at " + decl.address +
                             (v->digital ? ": a BOOL needs a bit address (%IX, %QX, %MX)"
                                         : ": a bit address (X) needs a BOOL"));
    else if (v->role == Var::Role::kInput || v->role == Var::Role::kSetpoint)
      emit_channel(*v);
  }
  return v;
}

// An HMI variable (docs/st.md, "HMI variables") is a channel labelled with its
// path: an operator set-point when the program never writes it, an output the
// console shows when it does. Its address is a hash of the path, so it stays
// the same across edits and swaps and differs between tasks: set-points at
// SETP d8..d255, outputs at DIO p8..p255 (the located ones stay below 8).
std::unique_ptr<Var> Lowering::hmi_var(std::unique_ptr<Var> v, bool in_function) {
  const Variable& decl = *v->decl;
  const bool has_storage = decl.section == VarSection::kLocal || decl.section == VarSection::kOutput ||
                           decl.section == VarSection::kGlobal;
  if (in_function || !has_storage) return v;  // a parameter or a reference: the HMI sees the variable it names
  const uint64_t h = fnv1a64(v->path);
  const auto high = static_cast<uint32_t>(8 + (h >> 16) % 248), low = static_cast<uint32_t>(h & 0xFFFF);
  Location l;
  l.size = v->digital ? 'X' : 'W';
  if (!written(*v)) {
    l.area = 'M';
    l.d = high;
    l.c = low;
    v->role = Var::Role::kSetpoint;
  } else {
    l.area = 'Q';
    l.p = high;
    l.c = low;
  }
  v->loc = l;
  v->hmi = true;
  const uint32_t address = high << 16 | low;
  for (const auto& [other, path] : hmi_addresses_) {
    if (other == address) {
      d_.error(decl.pos, "HMI variables '" + path + "' and '" + v->path +
                             "' hash to one channel address: rename one of them");
    }
  }
  hmi_addresses_.emplace_back(address, v->path);
  if (v->role == Var::Role::kSetpoint) emit_channel(*v);
  return v;
}

std::unique_ptr<Scope> Lowering::make_scope(const Pou& pou, const std::string& path, int depth) {
  auto s = std::make_unique<Scope>();
  s->path = path;
  s->pou = &pou;
  s->globals = globals_.get();
  s->function = pou.type == PouType::kFunction;
  for (const Variable& decl : pou.vars) {
    if (decl.section == VarSection::kExternal) continue;  // resolved through globals
    // The readers refuse a name declared twice; a second Var under one key
    // would be dropped by emplace while all_vars_ still points at it.
    if (s->vars.count(upper(decl.name))) {
      d_.error(decl.pos, "variable '" + decl.name + "' is declared twice in " + pou.name);
      continue;
    }
    if (decl.section == VarSection::kInOut) {
      if (pou.type == PouType::kProgram) {
        d_.error(decl.pos, "variable '" + decl.name + "': a program has no caller to pass VAR_IN_OUT");
        continue;
      }
      auto v = std::make_unique<Var>();
      v->decl = &decl;
      v->path = path + "." + decl.name;
      v->role = Var::Role::kInOut;
      s->vars.emplace(upper(decl.name), std::move(v));
      continue;
    }
    if (decl.section == VarSection::kGlobal) {
      d_.error(decl.pos, "variable '" + decl.name + "': globalVars inside a POU are not supported; declare it in the configuration or resource");
      continue;
    }
    if (!decl.address.empty() && pou.type != PouType::kProgram)
      d_.error(decl.pos, "variable '" + decl.name + "': only programs and the configuration may declare located variables");
    auto v = make_var(decl, path + "." + decl.name, depth, s->function);
    all_vars_.push_back(v.get());
    s->vars.emplace(upper(decl.name), std::move(v));
    if (decl.edge != 0) {
      // An R_EDGE (F_EDGE) input: an R_TRIG (F_TRIG) of the instance's own,
      // called at each call of the instance (call_fb), as MatIEC makes it.
      if (pou.type != PouType::kFunctionBlock) {
        d_.error(decl.pos, "variable '" + decl.name + "': R_EDGE and F_EDGE qualify inputs of a function block only");
        continue;
      }
      auto ed = std::make_unique<Variable>();
      ed->name = decl.name + "$edge";
      ed->type.base = BaseType::kDerived;
      ed->type.derived = decl.edge == 'R' ? "R_TRIG" : "F_TRIG";
      ed->pos = decl.pos;
      auto trig = make_var(*ed, path + "." + ed->name, depth, s->function);
      all_vars_.push_back(trig.get());
      s->vars.emplace(upper(ed->name), std::move(trig));
      owned_decls_.push_back(std::move(ed));
    }
  }
  for (const Variable& decl : pou.vars) {
    if (decl.section != VarSection::kExternal) continue;
    if (!globals_ || !globals_->vars.count(upper(decl.name)))
      d_.error(decl.pos, "external variable '" + decl.name + "' names no global variable of the configuration");
  }
  return s;
}

void Lowering::set_globals(const std::vector<const Variable*>& globals) {
  globals_ = std::make_unique<Scope>();
  for (const Variable* g : globals) {
    if (globals_->vars.count(upper(g->name))) {
      d_.error(g->pos, "global variable '" + g->name + "' is declared twice");
      continue;
    }
    auto v = make_var(*g, g->name, 0, false);
    all_vars_.push_back(v.get());
    globals_->vars.emplace(upper(g->name), std::move(v));
  }
}

Var* Lowering::lookup(Scope& s, const std::string& name, SourcePos pos, bool report) {
  const std::string up = upper(name);
  if (!up.empty() && up[0] == '%') {
    // A directly represented variable: an implicit global, labelled with its
    // address without the '%' (IX0_0 is not needed: '.' is allowed in labels).
    if (!globals_) globals_ = std::make_unique<Scope>();
    auto it = globals_->vars.find(up);
    if (it != globals_->vars.end()) return it->second.get();
    std::string err;
    auto loc = parse_location(up, &err);
    if (!loc) {
      d_.error(pos, err);
      return nullptr;
    }
    auto decl = std::make_unique<Variable>();
    decl->name = up.substr(1);
    decl->address = up;
    decl->type.base = loc->size == 'X'   ? BaseType::kBool
                      : loc->size == 'B' ? BaseType::kByte
                      : loc->size == 'W' ? BaseType::kInt
                      : loc->size == 'D' ? BaseType::kDint
                                         : BaseType::kLint;
    decl->section = VarSection::kGlobal;
    decl->pos = pos;
    const Variable& d = *decl;
    owned_decls_.push_back(std::move(decl));
    auto v = make_var(d, d.name, 0, false);
    Var* raw = v.get();
    all_vars_.push_back(raw);
    globals_->vars.emplace(up, std::move(v));
    return raw;
  }
  auto it = s.vars.find(up);
  if (it != s.vars.end()) {
    Var* v = it->second.get();
    if (v->role != Var::Role::kInOut) return v;
    if (!v->alias && report)
      d_.error(pos, "'" + name + "' is VAR_IN_OUT and this call passes no variable for it");
    return v->alias;
  }
  if (s.globals && s.pou) {
    const Variable* decl = s.pou->var(name);
    if (decl && decl->section == VarSection::kExternal) {
      auto g = s.globals->vars.find(up);
      if (g != s.globals->vars.end()) return g->second.get();
    }
    // Programs see the configuration's globals without declaring them
    // (OpenPLC and Beremiz habit); FBs and functions must declare VAR_EXTERNAL.
    if (s.pou->type == PouType::kProgram) {
      auto g = s.globals->vars.find(up);
      if (g != s.globals->vars.end()) return g->second.get();
    }
  }
  if (report) d_.error(pos, "'" + name + "' is not a variable of " + (s.pou ? "POU '" + s.pou->name + "'" : "the project"));
  return nullptr;
}

Var* Lowering::resolve_path(Scope& s, const std::string& path, SourcePos pos) {
  const size_t dot = path.empty() || path[0] == '%' ? std::string::npos : path.find('.');
  if (dot == std::string::npos) return lookup(s, path, pos);
  Var* base = lookup(s, path.substr(0, dot), pos);
  if (!base) return nullptr;
  if (base->role != Var::Role::kUserFb && base->role != Var::Role::kStruct) {
    d_.error(pos, "'" + path + "': '" + path.substr(0, dot) + "' is not a function block instance of this project");
    return nullptr;
  }
  return resolve_path(*base->fb, path.substr(dot + 1), pos);
}

std::vector<Place> Lowering::places(Scope& s, const std::string& path,
                                    const std::vector<std::unique_ptr<Expr>>& index, SourcePos pos) {
  const Value yes = constant(1, true);
  if (path.empty()) return {};
  if (path[0] == '%') {
    Var* v = lookup(s, path, pos);
    if (!v) return {};
    return {Place{yes, v, {}, false}};
  }
  auto both = [&](const Value& a, const Value& b) {
    if (a.is_const) return a.k != 0 ? b : a;
    if (b.is_const) return b.k != 0 ? a : b;
    return em_.binary(BinOp::kAnd, a, b, pos);
  };
  std::vector<Place> cur;
  size_t i = 0, next_index = 0;
  bool first = true;
  for (;;) {
    size_t j = i;
    while (j < path.size() && path[j] != '.' && path[j] != '[') ++j;
    const std::string name = path.substr(i, j - i);
    if (first) {
      Var* v = lookup(s, name, pos);
      if (!v) return {};
      cur = {Place{yes, v, {}, false}};
      first = false;
    } else {
      std::vector<Place> nx;
      for (const Place& p : cur) {
        Var* b = p.var;
        if (!p.output.empty()) {
          d_.error(pos, "'" + path + "': " + b->decl->name + "." + p.output + " has no members");
          return {};
        }
        if (b->role == Var::Role::kStruct || b->role == Var::Role::kUserFb) {
          auto it = b->fb->vars.find(upper(name));
          if (it != b->fb->vars.end() && it->second->role == Var::Role::kInOut) {
            d_.error(pos, "'" + path_text(path) + "': " + name + " is VAR_IN_OUT of '" + b->decl->name +
                              "': use the variable passed for it");
            return {};
          }
          if (it == b->fb->vars.end() && b->role == Var::Role::kUserFb && upper(name) == "ENO") {
            nx.push_back(Place{p.when, &eno_var(*b), {}, p.in_instance});
            continue;
          }
          if (it == b->fb->vars.end()) {
            d_.error(pos, "'" + path + "': " +
                              (b->role == Var::Role::kStruct ? "structure '" + b->decl->name + "' has no member '"
                                                             : "function block '" + b->fb->pou->name +
                                                                   "' has no variable '") +
                              name + "'");
            return {};
          }
          nx.push_back(Place{p.when, it->second.get(), {}, p.in_instance || b->role == Var::Role::kUserFb});
        } else if (b->role == Var::Role::kStdFb && upper(name) == "ENO") {
          nx.push_back(Place{p.when, &eno_var(*b), {}, p.in_instance});
        } else if (b->role == Var::Role::kStdFb) {
          nx.push_back(Place{p.when, b, upper(name), p.in_instance});
        } else {
          d_.error(pos, "'" + path + "': '" + b->decl->name + "' is neither a structure nor a function block instance");
          return {};
        }
      }
      cur = std::move(nx);
    }
    i = j;
    while (i < path.size() && path[i] == '[') {  // "[#n]": the next n index expressions
      const size_t close = path.find(']', i);
      const size_t n = static_cast<size_t>(std::strtoul(path.c_str() + i + 2, nullptr, 10));
      i = close + 1;
      std::vector<Value> ix;
      for (size_t k = 0; k < n && next_index < index.size(); ++k) ix.push_back(eval(s, *index[next_index++]));
      std::vector<Place> nx;
      for (const Place& p : cur) {
        Var* b = p.var;
        if (b->role != Var::Role::kArray || !p.output.empty()) {
          d_.error(pos, "'" + path + "': '" + b->decl->name + "' is not an array");
          return {};
        }
        const ArrayType& a = *b->array;
        if (ix.size() != a.dims.size()) {
          d_.error(pos, "'" + b->decl->name + "' has " + std::to_string(a.dims.size()) + " dimension" +
                            (a.dims.size() == 1 ? "" : "s") + ", indexed with " + std::to_string(ix.size()));
          return {};
        }
        const bool known = std::all_of(ix.begin(), ix.end(), [](const Value& x) { return x.is_const; });
        size_t stride = b->elems.size();
        if (known) {
          size_t off = 0;
          for (size_t d = 0; d < ix.size(); ++d) {
            const auto [lo, hi] = a.dims[d];
            stride /= static_cast<size_t>(hi - lo + 1);
            if (ix[d].k != std::floor(ix[d].k) || ix[d].k < static_cast<double>(lo) ||
                ix[d].k > static_cast<double>(hi)) {
              d_.error(pos, "index " + format_index(ix[d].k) + " is outside " + b->decl->name + "'s bounds " +
                                std::to_string(lo) + ".." + std::to_string(hi));
              return {};
            }
            off += static_cast<size_t>(static_cast<int64_t>(ix[d].k) - lo) * stride;
          }
          nx.push_back(Place{p.when, b->elems[off].get(), {}, p.in_instance});
          continue;
        }
        // Known at run time only: every element, under "the index is its own".
        for (size_t off = 0; off < b->elems.size(); ++off) {
          Value c = p.when;
          size_t rest = off, st = b->elems.size();
          for (size_t d = 0; d < ix.size() && !(c.is_const && c.k == 0); ++d) {
            const auto [lo, hi] = a.dims[d];
            st /= static_cast<size_t>(hi - lo + 1);
            const double at = static_cast<double>(lo + static_cast<int64_t>(rest / st));
            rest %= st;
            Value k = constant(at, false);
            k.integer = true;
            c = both(c, ix[d].is_const ? constant(ix[d].k == at ? 1 : 0, true) : em_.binary(BinOp::kEq, ix[d], k, pos));
          }
          if (c.is_const && c.k == 0) continue;
          nx.push_back(Place{c, b->elems[off].get(), {}, p.in_instance});
        }
      }
      cur = std::move(nx);
    }
    if (i >= path.size()) break;
    ++i;  // '.'
  }
  return cur;
}

Var* Lowering::whole_var(Scope& s, const std::string& path) {
  if (path.empty() || path[0] == '%' || path.find('[') != std::string::npos) return nullptr;
  Var* v = nullptr;
  size_t i = 0;
  while (i <= path.size()) {
    const size_t j = std::min(path.find('.', i), path.size());
    const std::string name = path.substr(i, j - i);
    if (!v) {
      v = lookup(s, name, SourcePos{}, false);
    } else if (v->role == Var::Role::kStruct || v->role == Var::Role::kUserFb) {
      auto it = v->fb->vars.find(upper(name));
      v = it == v->fb->vars.end() || it->second->role == Var::Role::kInOut ? nullptr : it->second.get();
    } else {
      return nullptr;
    }
    if (!v) return nullptr;
    i = j + 1;
  }
  return v && (v->role == Var::Role::kStruct || v->role == Var::Role::kArray) ? v : nullptr;
}

bool Lowering::assign_whole(Var& dst, Var& src, SourcePos pos) {
  auto shape_error = [&] {
    d_.error(pos, "'" + dst.decl->name + "' and '" + src.decl->name + "' are not of one type: a whole " +
                      (dst.role == Var::Role::kStruct ? "structure" : "array") + " takes one of its own type");
    return false;
  };
  if (dst.role != src.role) return shape_error();
  if (dst.role == Var::Role::kStruct) {
    if (dst.decl->type.derived.empty() || !iequals(dst.decl->type.derived, src.decl->type.derived) ||
        dst.fb->vars.size() != src.fb->vars.size())
      return shape_error();
    for (auto& [name, m] : dst.fb->vars) {
      auto it = src.fb->vars.find(name);
      if (it == src.fb->vars.end()) return shape_error();
      if (!assign_whole(*m, *it->second, pos)) return false;
    }
    return true;
  }
  if (dst.role == Var::Role::kArray) {
    if (dst.array->dims != src.array->dims || dst.elems.size() != src.elems.size()) return shape_error();
    for (size_t k = 0; k < dst.elems.size(); ++k) {
      if (!assign_whole(*dst.elems[k], *src.elems[k], pos)) return false;
    }
    return true;
  }
  assign(dst, read(src, pos), pos);
  return !d_.has_errors();
}

Var* Lowering::whole_member(const Var* fb, const std::string& formal) const {
  if (!fb || fb->role != Var::Role::kUserFb || formal.empty()) return nullptr;
  auto it = fb->fb->vars.find(upper(formal));
  if (it == fb->fb->vars.end()) return nullptr;
  Var* m = it->second.get();
  return m->role == Var::Role::kStruct || m->role == Var::Role::kArray ? m : nullptr;
}

bool Lowering::whole_parameter(const std::string& function, const std::string& formal) const {
  const Pou* p = proj_.pou(function);
  if (!p || p->type != PouType::kFunction || formal.empty()) return false;
  const Variable* d = p->var(formal);
  if (!d || d->section == VarSection::kInOut) return false;
  if (d->type.array) return true;
  const DataType* t = d->type.base == BaseType::kDerived ? proj_.data_type(d->type.derived) : nullptr;
  for (int hops = 0; t && t->kind == DataType::Kind::kAlias && hops < kMaxNesting; ++hops)
    t = t->alias.array ? nullptr : proj_.data_type(t->alias.derived);
  return t && (t->kind == DataType::Kind::kStruct || t->kind == DataType::Kind::kArray);
}

Var* Lowering::resolve_static(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                              SourcePos pos) {
  std::vector<Place> ps = places(s, path, index, pos);
  if (ps.empty()) return nullptr;
  if (ps.size() != 1 || !ps[0].when.is_const) {
    d_.error(pos, "'" + path_text(path) + "': an array index known only at run time is supported in ST "
                  "expressions and assignments; here it must be a constant");
    return nullptr;
  }
  if (!ps[0].output.empty()) {
    d_.error(pos, "'" + path_text(path) + "' is an output of function block '" + ps[0].var->decl->name + "'");
    return nullptr;
  }
  return ps[0].var;
}

Var* Lowering::indexed_array(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                             SourcePos pos, Value& index_value) {
  if (loops_.empty() || index.size() != 1 || path.size() < 5 || path.compare(path.size() - 4, 4, "[#1]") != 0) {
    return nullptr;
  }
  const std::string base = path.substr(0, path.size() - 4);
  if (base.find_first_of(".[%") != std::string::npos) return nullptr;
  Var* a = lookup(s, base, pos, false);
  if (!a || a->role != Var::Role::kArray || !a->array || a->array->dims.size() != 1 || a->elems.empty()) return nullptr;
  for (const auto& e : a->elems) {
    // (a STRING element is read and written by a choice among the elements:
    // pick and put move numbers)
    if (e->role != Var::Role::kPlain || e->str) return nullptr;
  }
  // Evaluated once here; the caller uses it instead of places() evaluating it.
  index_value = eval(s, *index[0]);
  if (index_value.is_const) return nullptr;
  return a;
}

Lowering::LoopHome Lowering::make_home_for(const Value& v, const std::string& stem, SourcePos pos) {
  return make_home(stem, v.digital, v.integer, pos, v.str ? std::optional<uint32_t>(v.cap) : std::nullopt, v.wide);
}

Lowering::LoopHome Lowering::make_home_for(const Var& v, SourcePos pos) {
  return make_home(v.path, v.digital, v.integer, pos, v.str ? std::optional<uint32_t>(v.cap) : std::nullopt, v.wide);
}

Lowering::LoopHome Lowering::make_home(const std::string& stem, bool digital, bool integer, SourcePos pos,
                                       std::optional<uint32_t> str_cap, bool wide) {
  LoopHome h;
  h.value.ref = em_.fresh(stem + "$loop");
  if (str_cap) {
    h.block = em_.emit_flow("svar", h.value.ref, pos, {}, 0, {static_cast<double>(*str_cap)});
    h.value.str = true;
    h.value.wide = wide;
    h.value.cap = *str_cap;
    return h;
  }
  h.block = em_.emit_flow(digital ? "dvar" : "var", h.value.ref, pos, {}, 0, {0.0});
  h.value.digital = digital;
  h.value.integer = integer;
  return h;
}

void Lowering::set_home(const LoopHome& h, const Value& v, SourcePos pos) {
  if (h.value.str != v.str || h.value.wide != v.wide) {
    d_.error(pos, "a value that is a STRING on one way here and a number on another (an IL current result "
                  "at a label or a loop's head): load it again after the label");
    return;
  }
  if (h.value.str) {
    em_.emit_flow("sset", em_.fresh(h.value.ref + "$set"), pos, {em_.ref(v, pos)}, static_cast<uint32_t>(h.block),
                  {static_cast<double>(h.value.cap)});
    return;
  }
  const Value k = h.value.digital ? em_.to_digital(v, pos) : em_.to_analog(v, pos);
  em_.emit_flow(h.value.digital ? "dset" : "set", em_.fresh(h.value.ref + "$set"), pos, {em_.ref(k, pos)},
                static_cast<uint32_t>(h.block));
}

void Lowering::set_homes(const std::vector<std::pair<const LoopHome*, Value>>& sets, SourcePos pos) {
  std::set<std::string> targets;
  for (const auto& [h, v] : sets) targets.insert(h->value.ref);
  std::vector<std::pair<const LoopHome*, Value>> todo;
  for (const auto& [h, v] : sets) {
    if (!v.is_const && v.ref == h->value.ref) continue;
    Value x = v;
    if (!x.is_const && targets.count(x.ref) != 0) {
      // Read before any home is written: a copy of its value now.
      x.ref = em_.fresh(h->value.ref + "$was");
      em_.copy_as(v, x.ref, pos, v.cap);
    }
    todo.emplace_back(h, x);
  }
  for (const auto& [h, x] : todo) set_home(*h, x, pos);
}

void Lowering::sync_homes(const std::vector<std::pair<Var*, const LoopHome*>>& homes, SourcePos pos) {
  std::vector<std::pair<const LoopHome*, Value>> sets;
  for (const auto& [v, h] : homes) sets.emplace_back(h, read(*v, pos));
  set_homes(sets, pos);
}

bool Lowering::sync_home(Var& v, const LoopHome& h, SourcePos pos) {
  const Value now = read(v, pos);
  if (!now.is_const && now.ref == h.value.ref) return false;
  set_home(h, now, pos);
  return true;
}

Value Lowering::load(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                     SourcePos pos) {
  {
    Value ix;
    if (Var* a = indexed_array(s, path, index, pos, ix)) {
      std::vector<std::string> table;
      for (const auto& e : a->elems) table.push_back(em_.ref(read(*e, pos), pos));
      const Var& e0 = *a->elems[0];
      Value r;
      r.ref = em_.fresh("pick");
      r.digital = e0.digital;
      r.integer = e0.integer;
      if (e0.integer) r.int_type = iec_type(e0.decl->type.base);
      if (iec::time_grid(iec_type(e0.decl->type.base)) != 0) r.time_type = iec_type(e0.decl->type.base);
      em_.emit_indexed(e0.digital ? "dpick" : "pick", r.ref, pos, {em_.ref(em_.to_analog(ix, pos), pos)},
                       std::move(table), static_cast<double>(a->array->dims[0].first));
      return r;
    }
    if (d_.has_errors()) return constant(0, false);
  }
  if (index.empty() && path.find('.') == std::string::npos && !lookup(s, path, pos, false)) {
    if (auto k = proj_.enum_value(path)) {  // an enumeration's value: its position
      Value v = constant(*k, false);
      v.integer = true;
      return v;
    }
  }
  if (index.empty()) {
    if (std::optional<Value> v = step_member(s, path, pos)) return *v;
  }
  std::vector<Place> ps = places(s, path, index, pos);
  if (ps.empty()) return constant(0, false);
  auto value_of = [&](const Place& p) {
    if (!p.output.empty()) return fb_output(*p.var, p.output, pos);
    return p.in_instance ? read_from_outside(*p.var, pos) : read(*p.var, pos);
  };
  if (ps.size() == 1 && ps[0].when.is_const && ps[0].when.k != 0) return value_of(ps[0]);
  std::vector<Value> vs;
  for (const Place& p : ps) vs.push_back(value_of(p));
  Value acc = constant(0, vs[0].digital);  // an index out of range reads 0 ('' for strings)
  if (vs[0].str) acc = string_constant("", vs[0].wide);
  acc.integer = vs[0].integer;
  for (size_t k = ps.size(); k-- > 0;) acc = em_.select(ps[k].when, vs[k], acc, pos);
  acc.integer = vs[0].integer;
  acc.int_type = vs[0].int_type;
  return acc;
}

void Lowering::store(Scope& s, const std::string& path, const std::vector<std::unique_ptr<Expr>>& index,
                     const Value& v, SourcePos pos) {
  {
    Value ix;
    Var* a = indexed_array(s, path, index, pos, ix);
    if (d_.has_errors()) return;
    static const std::map<const Var*, LoopHome> kNone;
    const auto& homes = loops_.empty() ? kNone : loops_.back();
    const bool homed = a && std::all_of(a->elems.begin(), a->elems.end(),
                                        [&](const auto& e) { return homes.count(e.get()) != 0; });
    if (a && homed) {
      const Var& e0 = *a->elems[0];
      const double lo = static_cast<double>(a->array->dims[0].first);
      std::vector<std::string> table;
      for (const auto& e : a->elems) {
        // Every element in its home first: the put writes there, and a later
        // read of any element reads there.
        const LoopHome& h = homes.at(e.get());
        if (sync_home(*e, h, pos)) e->cur = h.value;
        table.push_back(h.value.ref);
      }
      Value at = em_.to_analog(ix, pos);
      // Inside an IF branch (computed whatever the condition), a write that
      // is not taken goes nowhere: the index points before the table.
      if (!path_.empty()) at = em_.select(active(pos), at, constant(lo - 1, false), pos);
      const Value val = coerce(const_cast<Var&>(e0), v, pos);
      em_.emit_indexed(e0.digital ? "dput" : "put", em_.fresh("put"), pos, {em_.ref(at, pos), em_.ref(val, pos)},
                       std::move(table), lo);
      return;
    }
    if (a) {
      // Not every element has a home here: the choice among the elements,
      // on the index already evaluated.
      for (size_t k = 0; k < a->elems.size(); ++k) {
        Var& e = *a->elems[k];
        const Value when =
            em_.binary(BinOp::kEq, ix, constant(static_cast<double>(a->array->dims[0].first) + static_cast<double>(k), false), pos);
        assign(e, em_.select(when, v, read(e, pos), pos), pos);
        if (d_.has_errors()) return;
      }
      return;
    }
  }
  for (const Place& p : places(s, path, index, pos)) {
    if (!p.output.empty()) {
      d_.error(pos, "'" + path_text(path) + "' is an output of function block '" + p.var->decl->name +
                        "': it cannot be assigned");
      return;
    }
    if (p.when.is_const && p.when.k != 0) assign(*p.var, v, pos);
    else assign(*p.var, em_.select(p.when, v, read(*p.var, pos), pos), pos);
    if (d_.has_errors()) return;
  }
}

Value Lowering::start_value(Var& v, SourcePos pos) {
  if (v.start) return *v.start;
  Value init = v.str ? string_constant("", v.wide) : constant(0, v.digital);
  if (!v.decl->initial.empty() && v.str) {
    std::string error;
    bool wide = false;
    const auto text = parse_string_literal(v.decl->initial, &error, &wide);
    if (!text) {
      d_.error(v.decl->pos, "variable '" + v.decl->name + "': initial value " + v.decl->initial + ": " + error);
    } else if (wide != v.wide) {
      d_.error(v.decl->pos, "variable '" + v.decl->name + "' is a " + (v.wide ? "WSTRING: its initial value is \"...\""
                                                                              : "STRING: its initial value is '...'"));
    } else {
      init = em_.cut_string(string_constant(*text, wide), v.cap, v.decl->pos);
    }
  } else if (!v.decl->initial.empty()) {
    bool b = false;
    auto k = parse_literal(v.decl->initial, &b);
    if (!k) {
      d_.error(v.decl->pos, "variable '" + v.decl->name + "': initial value '" + v.decl->initial +
                                "' is not a literal rtplc reads");
    } else {
      init = constant(*k, v.digital);
    }
  }
  init.integer = v.integer;
  if (v.role == Var::Role::kInput || v.role == Var::Role::kSetpoint) {
    Value r;
    r.ref = v.path;
    r.digital = v.digital;
    r.integer = v.integer;
    v.start = r;
    return r;
  }
  // In a function nothing is remembered: each call starts from the initial
  // value; so does a VAR_TEMP at each cycle (and each call: call_fb).
  const bool in_function = v.path.find("()") != std::string::npos;
  if (in_function || v.decl->constant || v.decl->section == VarSection::kTemp) {
    v.start = init;
    return init;
  }
  Value prev;
  prev.ref = v.path;  // the end-of-cycle copy, which runs later: last cycle's value
  prev.digital = v.digital;
  prev.integer = v.integer;
  prev.str = v.str;
  prev.wide = v.wide;
  prev.cap = v.cap;
  if (v.str ? init.text.empty() : init.k == 0) {
    v.start = prev;
  } else {
    Value s = em_.select(em_.first_cycle(pos), init, prev, pos);
    s.integer = v.integer;
    v.start = s;
  }
  return *v.start;
}

Value Lowering::read_from_outside(Var& v, SourcePos pos) {
  auto saved = before_read;
  before_read = nullptr;
  Value r = read(v, pos);
  before_read = saved;
  return r;
}

Value Lowering::read(Var& v, SourcePos pos) {
  if (v.role == Var::Role::kStruct || v.role == Var::Role::kArray) {
    d_.error(pos, "'" + v.decl->name + "' is " + (v.role == Var::Role::kStruct ? "a structure" : "an array") +
                      ": read one " + (v.role == Var::Role::kStruct ? "member" : "element") +
                      " at a time (a whole one is not a value rtplc can pass yet)");
    return constant(0, false);
  }
  if (v.role == Var::Role::kUserFb || v.role == Var::Role::kStdFb) {
    d_.error(pos, "'" + v.decl->name + "' is a function block instance; read one of its outputs (" +
                      v.decl->name + ".Q)");
    return constant(0, false);
  }
  if (before_read) {
    before_read(upper(v.decl->name));
    if (!v.decl->address.empty()) before_read(upper(v.decl->address));  // %QX0.0 written directly
  }
  Value r = v.cur ? *v.cur : start_value(v, pos);
  if (v.integer) r.int_type = iec_type(v.decl->type.base);
  if (iec::time_grid(iec_type(v.decl->type.base)) != 0) r.time_type = iec_type(v.decl->type.base);
  return r;
}

void Lowering::assign(Var& v, Value value, SourcePos pos) {
  if (v.role == Var::Role::kInput && written_inputs_.insert(&v).second) {
    // MatIEC's programs write through the pointer into the input image, which
    // the runtime fills again before the next cycle: what is written lasts for
    // the rest of this cycle. So here: later reads in the cycle see it, the
    // next cycle reads the input again (no copy block keeps it).
    out_.notes.push_back("'" + v.decl->name + "' is an input (" + v.decl->address + ") the program writes (line " +
                         std::to_string(pos.line) + "): what it writes lasts until the next cycle reads the input "
                         "again, as in MatIEC (OpenPLC, Beremiz)");
  }
  if (v.role == Var::Role::kUserFb || v.role == Var::Role::kStdFb) {
    d_.error(pos, "'" + v.decl->name + "' is a function block instance and cannot be assigned");
    return;
  }
  if (v.role == Var::Role::kStruct || v.role == Var::Role::kArray) {
    d_.error(pos, "'" + v.decl->name + "' is " + (v.role == Var::Role::kStruct ? "a structure" : "an array") +
                      ": assign one " + (v.role == Var::Role::kStruct ? "member" : "element") +
                      " at a time (whole assignment is not supported yet)");
    return;
  }
  if (v.decl->constant) {
    d_.error(pos, "'" + v.decl->name + "' is CONSTANT");
    return;
  }
  if (v.role == Var::Role::kSetpoint) {
    d_.error(pos, "internal: set-point '" + v.decl->name + "' written");
    return;
  }
  v.cur = coerce(v, value, pos);
}

Value Lowering::coerce(Var& v, Value value, SourcePos pos) {
  if (v.str || value.str) {
    if (!v.str || !value.str || v.wide != value.wide) {
      d_.error(pos, v.str && value.str
                        ? "'" + v.decl->name + "' is a " + (v.wide ? "WSTRING" : "STRING") + ": convert the " +
                              (v.wide ? "STRING (STRING_TO_WSTRING)" : "WSTRING (WSTRING_TO_STRING)")
                    : v.str ? "'" + v.decl->name + "' is a STRING: convert the number (INT_TO_STRING, TO_STRING, ...)"
                            : "a STRING assigned to '" + v.decl->name + "', which is " + type_name(v.decl->type) +
                                  ": convert it (STRING_TO_INT, ...)");
      return v.str ? string_constant("", v.wide) : constant(0, v.digital);
    }
    return value.cap > v.cap ? em_.cut_string(value, v.cap, pos) : value;
  }
  value = v.digital ? em_.to_digital(value, pos) : em_.to_analog(value, pos);
  if (value.is_const && !std::isfinite(value.k)) {
    d_.error(pos, "the value assigned to '" + v.decl->name +
                      "' is a constant expression that overflows (or divides by zero): folded, it is not a finite number");
    value.k = 0;  // one error, not a second one at the constant block
  }
  if (v.integer && value.is_const) {
    // A constant is wrapped here, by the rule `wrap` follows at run time.
    const iec::IecTypeInfo& t = iec::type_info(iec_type(v.decl->type.base));
    if (t.integer) {
      value.k = int_math::wrap_whole(value.k, int_math::type_modulus(t.bits), int_math::type_half(t.bits, t.is_signed));
    }
  } else if (const double per = iec::time_grid(iec_type(v.decl->type.base)); per > 0 && !v.digital) {
    // A TIME or TOD lands on the nanosecond grid, so its sums do not drift:
    // round(x * 1e9) / 1e9. A DATE or DT, seconds since 1970, on the
    // microsecond grid (iec::time_grid).
    value = on_time_grid(value, per, pos);
  } else if (v.integer) {
    // IEC integers wrap (an INT counter goes 32767 -> -32768): the value is
    // truncated and wrapped into the variable's range.
    const iec::IecTypeInfo& t = iec::type_info(iec_type(v.decl->type.base));
    const std::vector<double> params = {static_cast<double>(t.bits), t.is_signed ? 1.0 : 0.0};
    // ADD on an INT already wrapped its sum into INT: not twice.
    if (!em_.recent_block_is(value.ref, "wrap", params)) {
      Value w;
      w.ref = em_.fresh("wrap");
      em_.emit("wrap", w.ref, pos, {value.ref}, params);
      value = w;
    }
  }
  value.integer = v.integer;
  return value;
}

Value Lowering::on_time_grid(const Value& value, double per, SourcePos pos) {
  if (value.is_const) {
    Value c = value;
    c.k = int_math::snap_to(value.k, per);
    return c;
  }
  const std::string scaled = em_.fresh("time_ns"), whole = em_.fresh("time_ns");
  em_.emit("scale", scaled, pos, {value.ref}, {per, 0.0});
  em_.emit("round", whole, pos, {scaled});
  Value t;
  t.ref = em_.fresh("time");
  em_.emit("div", t.ref, pos, {whole, em_.ref(constant(per, false), pos)});
  return t;
}

Value Lowering::rising(const Value& v, const std::string& mem, SourcePos pos) {
  edge_memories_.push_back(EdgeMemory{v, mem, pos});
  Value m;
  m.ref = mem;
  m.digital = true;
  return em_.binary(BinOp::kAnd, v, em_.unary_not(m, pos), pos);
}

Value Lowering::falling(const Value& v, const std::string& mem, SourcePos pos) {
  const Value n = em_.unary_not(v, pos);
  return rising(n, mem, pos);
}

std::vector<std::optional<Value>> Lowering::save() const {
  std::vector<std::optional<Value>> st;
  st.reserve(all_vars_.size());
  for (const Var* v : all_vars_) st.push_back(v->cur);
  return st;
}

void Lowering::restore(const std::vector<std::optional<Value>>& st) {
  for (size_t i = 0; i < all_vars_.size() && i < st.size(); ++i) all_vars_[i]->cur = st[i];
  for (size_t i = st.size(); i < all_vars_.size(); ++i) all_vars_[i]->cur.reset();
}

// ---- bodies ----

void Lowering::lower_body(Scope& s) {
  lowered_pous_.insert(s.pou);  // its body compiled: check_unreached need not
  lower_body_of(s, s.pou->body);
}

void Lowering::lower_body_of(Scope& s, const Body& b) {
  switch (b.language) {
    case BodyLanguage::kFbd:
      lower_graph(s, *b.graph, false);
      break;
    case BodyLanguage::kLd:
      lower_graph(s, *b.graph, true);
      break;
    case BodyLanguage::kSt: {
      Block blk = parse_st(b.source, *b.text, d_);
      if (!d_.has_errors()) lower_st(s, blk);
      break;
    }
    case BodyLanguage::kIl:
      lower_il(s, b);
      break;
    case BodyLanguage::kSfc:
      if (&b != &s.pou->body) {
        d_.error(b.pos, "an SFC inside an SFC action is not supported");
        break;
      }
      lower_sfc(s, *b.graph);
      break;
    case BodyLanguage::kNone:
      break;
  }
}

void Lowering::finalize(Scope& s) {
  for (auto& [name, vp] : s.vars) finalize_var(*vp);
}

void Lowering::finalize_var(Var& v) {
  if (v.role == Var::Role::kInOut) return;  // the caller's variable: finalized there
  {
    if (v.role == Var::Role::kUserFb || v.role == Var::Role::kStruct) {
      finalize(*v.fb);
      return;
    }
    if (v.role == Var::Role::kArray) {
      for (auto& e : v.elems) finalize_var(*e);
      return;
    }
    if (v.role == Var::Role::kStdFb) {
      for (const std::string& n : produced_) {
        if (n.compare(0, v.path.size() + 1, v.path + ".") == 0) out_.variables.push_back(n);
      }
      return;
    }
    const SourcePos pos = v.decl->pos;
    out_.variables.push_back(v.path);
    if (v.role == Var::Role::kInput || v.role == Var::Role::kSetpoint) return;
    em_.copy_as(read(v, pos), v.path, pos, v.cap);
    if (v.loc && v.loc->area == 'Q' && drives_output(v)) {
      place_channel(em_.block(em_.emit(v.digital ? "ddo" : "dao", "", pos, {v.path})), v);
    }
  }
}

bool Lowering::written(const Var& v) const {
  return std::find(written_.begin(), written_.end(), upper(v.decl->name)) != written_.end() ||
         std::find(written_.begin(), written_.end(), upper(v.decl->address)) != written_.end();
}

bool Lowering::drives_output(Var& v) {
  // Two variables at one %Q address are one output: the one the program
  // writes drives it (OpenPLC accepts such aliases); two that are both
  // written would be two writers of one channel.
  const Location& l = *v.loc;
  auto same = [&](const Location& m) { return m.area == 'Q' && m.size == l.size && m.p == l.p && m.d == l.d && m.c == l.c; };
  for (const Var* u : outputs_) {
    if (!same(*u->loc)) continue;
    if (written(v) && written(*u)) {
      d_.error(v.decl->pos, "'" + v.decl->name + "' and '" + u->decl->name + "' (line " +
                                std::to_string(u->decl->pos.line) + ") are both at " + v.decl->address +
                                " and both written: an output has one writer");
    }
    return false;  // that one drives it
  }
  if (!written(v)) {
    // Unwritten: it leaves the output to a written alias declared anywhere.
    std::vector<const Variable*> decls;
    for (const Pou& pou : proj_.pous)
      for (const Variable& d : pou.vars) decls.push_back(&d);
    for (const Configuration& c : proj_.configurations) {
      for (const Variable& d : c.globals) decls.push_back(&d);
      for (const Resource& r : c.resources)
        for (const Variable& d : r.globals) decls.push_back(&d);
    }
    for (const Variable* d : decls) {
      if (d == v.decl || d->address.empty() || iequals(d->name, v.decl->name)) continue;
      std::string err;
      const auto m = parse_location(d->address, &err);
      if (!m || !same(*m)) continue;
      if (std::find(written_.begin(), written_.end(), upper(d->name)) != written_.end()) return false;
    }
  }
  outputs_.push_back(&v);
  return true;
}

Var& Lowering::eno_var(const Var& fb) {
  auto it = eno_vars_.find(&fb);
  if (it != eno_vars_.end()) return *it->second;
  // A function block instance's ENO: TRUE until a call with EN sets it to
  // that EN (the ST parser writes `inst.ENO := EN` after such a call); kept
  // across cycles like any variable (finish() finalizes it).
  auto decl = std::make_unique<Variable>();
  decl->name = fb.decl->name + ".ENO";
  decl->type.base = BaseType::kBool;
  decl->initial = "TRUE";
  decl->pos = fb.decl->pos;
  auto v = make_var(*decl, fb.path + ".ENO", 0, false);
  all_vars_.push_back(v.get());
  owned_decls_.push_back(std::move(decl));
  return *eno_vars_.emplace(&fb, std::move(v)).first->second;
}

void Lowering::program_instance(const Pou& pou, const std::string& path,
                                const std::vector<PouInstance::Connection>& connections) {
  programs_.push_back(make_scope(pou, path, 0));
  Scope& s = *programs_.back();
  s.called = true;
  // The instance's connections (PouInstance::Connection): each names an input
  // or output of the program; its source or sink is read in the
  // configuration's scope (the globals and direct variables).
  if (!globals_) globals_ = std::make_unique<Scope>();
  std::vector<std::pair<Var*, std::unique_ptr<Expr>>> outputs;
  for (const PouInstance::Connection& c : connections) {
    if (!c.text) continue;
    auto it = s.vars.find(upper(c.formal));
    const VarSection want = c.output ? VarSection::kOutput : VarSection::kInput;
    if (it == s.vars.end() || !it->second->decl || it->second->decl->section != want) {
      d_.error(c.pos, "program " + pou.name + " has no " + (c.output ? "VAR_OUTPUT '" : "VAR_INPUT '") + c.formal +
                          "' to connect" + (c.output ? " with =>" : " with :="));
      continue;
    }
    auto e = parse_st_expression(c.text->text, *c.text, d_);
    if (!e) continue;
    if (c.output) {
      if (e->kind != Expr::Kind::kName || e->name.find('[') != std::string::npos) {
        d_.error(c.pos, "'" + c.formal + " =>' connects to a global variable or a direct variable (%QX0.0)");
        continue;
      }
      outputs.emplace_back(it->second.get(), std::move(e));
    } else {
      assign(*it->second, eval(*globals_, *e), c.pos);
    }
  }
  if (trigger_.empty()) {
    lower_body(s);
  } else {
    // An event task: the body runs in the cycles its single="..." variable
    // rises (R_TRIG, memory FALSE at start), and keeps everything otherwise.
    Var* t = lookup(s, trigger_, trigger_pos_);
    if (!t) return;
    if (!t->digital) {
      d_.error(trigger_pos_, "single=\"" + trigger_ + "\" names a variable that is not BOOL");
      return;
    }
    const Value fire = rising(read(*t, trigger_pos_), s.path + ".$single", trigger_pos_);
    guarded(fire, trigger_pos_, [&] { lower_body(s); });
  }
  for (const auto& [v, e] : outputs) store(*globals_, e->name, e->args, read(*v, e->pos), e->pos);
  finalize(s);
}

void Lowering::set_trigger(const std::string& variable, SourcePos pos) {
  trigger_ = variable;
  trigger_pos_ = pos;
}

}  // namespace rtplc::lang::plcopen
