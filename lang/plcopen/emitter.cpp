// Values and primitive blocks for the PLCopen lowering (see emitter.h).
#include "lang/plcopen/emitter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <unordered_map>

#include "blocks/registry.h"
#include "blocks/string_ops.h"

namespace rtplc::lang::plcopen {

Value constant(double k, bool digital) {
  Value v;
  v.is_const = true;
  v.digital = digital;
  v.k = digital ? (k != 0 ? 1.0 : 0.0) : k;
  return v;
}

Value string_constant(std::string text, bool wide) {
  Value v;
  v.is_const = true;
  v.str = true;
  v.wide = wide;
  v.cap = static_cast<uint32_t>(wide ? utf16_units(text).size() : text.size());
  v.text = std::move(text);
  return v;
}

namespace {
constexpr const char* kFalse = "plcopen.false";
constexpr const char* kTrue = "plcopen.true";
constexpr const char* kFirst = "plcopen.first";
constexpr const char* kOne = "plcopen.one";
}  // namespace

size_t Emitter::emit(const std::string& written, std::string name, SourcePos pos,
                     std::vector<std::string> ins, std::vector<double> params) {
  FlatBlock b;
  b.written = written;
  b.name = std::move(name);
  b.pos = pos;
  b.n_in = static_cast<uint32_t>(ins.size() > 3 ? 3 : ins.size());
  for (uint32_t k = 0; k < b.n_in; ++k) b.in_pos[k] = pos;
  b.params = std::move(params);
  p_.blocks.push_back(std::move(b));
  refs_.push_back(std::move(ins));
  resolved_.push_back(false);
  return p_.blocks.size() - 1;
}

size_t Emitter::emit_flow(const char* written, std::string name, SourcePos pos, std::vector<std::string> ins,
                          uint32_t target, std::vector<double> params) {
  const size_t i = emit(written, std::move(name), pos, std::move(ins), std::move(params));
  p_.blocks[i].spec = flow_block(written);
  p_.blocks[i].target = target;
  return i;
}

size_t Emitter::emit_indexed(const char* written, std::string name, SourcePos pos, std::vector<std::string> ins,
                             std::vector<std::string> table, double lo) {
  const size_t i = emit_flow(written, std::move(name), pos, std::move(ins), 0, {lo});
  tables_[i] = std::move(table);
  return i;
}

void Emitter::adopt(size_t first, const std::function<std::string(uint32_t)>& input_name) {
  for (size_t i = first; i < p_.blocks.size(); ++i) {
    FlatBlock& b = p_.blocks[i];
    b.call_line = 0;  // a PLCopen block is the user's own, not inside a macro call
    std::vector<std::string> ins;
    for (uint32_t k = 0; k < b.n_in; ++k) ins.push_back(k < 3 ? input_name(b.in[k]) : "");
    refs_.push_back(std::move(ins));
    resolved_.push_back(false);  // an input may name a block made later
  }
}

void Emitter::append_resolved(FlatBlock b) {
  p_.blocks.push_back(std::move(b));
  refs_.emplace_back();
  resolved_.push_back(true);
}

void Emitter::append_named(FlatBlock b, std::vector<std::string> ins) {
  b.call_line = 0;
  p_.blocks.push_back(std::move(b));
  refs_.push_back(std::move(ins));
  resolved_.push_back(false);
}

std::string Emitter::fresh(const std::string& scope) {
  return scope + ".$" + std::to_string(++counter_);
}

bool Emitter::recent_block_is(const std::string& ref, const char* written, const std::vector<double>& params) const {
  constexpr size_t kLookBack = 8;  // the producer is almost always the last block
  for (size_t n = 0; n < kLookBack && n < p_.blocks.size(); ++n) {
    const FlatBlock& b = p_.blocks[p_.blocks.size() - 1 - n];
    if (b.name != ref) continue;
    if (b.written != written || b.params.size() < params.size()) return false;
    return std::equal(params.begin(), params.end(), b.params.begin());
  }
  return false;
}

bool Emitter::has_block(const char* name) const { return find_block(name) != nullptr; }

void Emitter::missing_block(const char* block, const std::string& what, SourcePos pos) {
  if (reported_missing_[block]) return;
  reported_missing_[block] = true;
  d_.error(pos, what + " needs the primitive block '" + block +
                    "', which this build does not have (docs/plcopen.md, \"Not supported yet\")");
}

std::string Emitter::ref(const Value& v, SourcePos pos) {
  if (!v.is_const) return v.ref;
  if (v.str) {
    // One sconst block per text; its label holds the text.
    const std::string key = std::string(v.wide ? "\x01w" : "\x01s") + v.text;
    auto it = consts_.find(key);
    if (it != consts_.end()) return it->second;
    const std::string name = fresh("plcopen.s");
    emit_flow("sconst", name, pos, {}, 0, {v.wide ? 1.0 : 0.0});
    p_.blocks.back().label = v.text;
    consts_[key] = name;
    return name;
  }
  char buf[48];
  if (v.digital) std::snprintf(buf, sizeof buf, "%s", v.k != 0 ? kTrue : kFalse);
  else {
    // The shortest spelling that reads back exactly ("k:0.8", not "k:0.80000000000000004").
    for (int prec = 6; prec <= 17; ++prec) {
      std::snprintf(buf, sizeof buf, "k:%.*g", prec, v.k);
      if (std::strtod(buf + 2, nullptr) == v.k) break;
    }
  }
  auto it = consts_.find(buf);
  if (it != consts_.end()) return it->second;
  consts_[buf] = buf;
  emit(v.digital ? "dconst" : "const", buf, pos, {}, {v.digital ? (v.k != 0 ? 1.0 : 0.0) : v.k});
  return buf;
}

Value Emitter::string_block(const char* written, const std::string& stem, SourcePos pos,
                            std::vector<std::string> ins, std::vector<double> params, uint32_t cap, bool wide) {
  Value r;
  r.ref = fresh(stem);
  const BlockSpec* spec = flow_block(written);
  emit_flow(written, r.ref, pos, std::move(ins), 0, std::move(params));
  r.str = spec != nullptr && spec->out_kind == Kind::kString;
  r.digital = spec != nullptr && spec->out_kind == Kind::kDigital;
  r.cap = r.str ? cap : 0;
  r.wide = r.str && wide;
  return r;
}

Value Emitter::cut_string(const Value& v, uint32_t cap, SourcePos pos) {
  if (v.cap <= cap) return v;
  if (v.is_const) {
    if (!v.wide) return string_constant(v.text.substr(0, cap));
    std::vector<uint16_t> units = utf16_units(v.text);
    units.resize(cap);
    return string_constant(utf8_of_units(units), true);
  }
  return string_block("scopy", "scopy", pos, {v.ref}, {static_cast<double>(cap), v.wide ? 1.0 : 0.0}, cap, v.wide);
}

// A STRING where a number is needed: said once here, whatever asked.
static bool refuse_string(const Value& v, DiagnosticList& d, SourcePos pos) {
  if (!v.str) return false;
  d.error(pos, "a STRING where a number is needed: convert it (STRING_TO_INT, STRING_TO_REAL, LEN, ...)");
  return true;
}

Value Emitter::to_analog(const Value& v, SourcePos pos) {
  if (refuse_string(v, d_, pos)) return constant(0, false);
  if (!v.digital) return v;
  if (v.is_const) return constant(v.k, false);
  Value r;
  r.ref = fresh("b2a");
  emit("d2a", r.ref, pos, {v.ref});
  return r;
}

Value Emitter::to_digital(const Value& v, SourcePos pos) {
  if (refuse_string(v, d_, pos)) return constant(0, true);
  if (v.digital) return v;
  if (v.is_const) return constant(v.k != 0 ? 1 : 0, true);
  Value r;
  r.digital = true;
  r.ref = fresh("a2b");
  emit("a2d", r.ref, pos, {v.ref});
  return r;
}

Value Emitter::unary_not(const Value& v, SourcePos pos) {
  if (!v.digital) {
    Value r;
    r.integer = true;
    r.ref = fresh("bnot");
    emit("bnot", r.ref, pos, {ref(v, pos)});
    return r;
  }
  if (v.is_const) return constant(v.k != 0 ? 0 : 1, true);
  Value r;
  r.digital = true;
  r.ref = fresh("not");
  emit("not", r.ref, pos, {v.ref});
  return r;
}

Value Emitter::negate(const Value& v, SourcePos pos) {
  Value a = to_analog(v, pos);
  if (a.is_const) {
    Value c = constant(-a.k, false);
    c.integer = a.integer;
    return c;
  }
  Value r;
  r.integer = a.integer;
  r.ref = fresh("neg");
  emit("scale", r.ref, pos, {a.ref}, {-1.0, 0.0});
  return r;
}

Value Emitter::binary(BinOp op, const Value& a0, const Value& b0, SourcePos pos) {
  const bool logic = op == BinOp::kAnd || op == BinOp::kOr || op == BinOp::kXor;
  const bool compare = op >= BinOp::kEq;
  if (a0.str || b0.str) {
    if (a0.str && b0.str && a0.wide != b0.wide) {
      d_.error(pos, "a STRING and a WSTRING together: convert one (STRING_TO_WSTRING, WSTRING_TO_STRING)");
      return constant(0, compare);
    }
    if (!(a0.str && b0.str) || !compare) {
      d_.error(pos, a0.str && b0.str ? "this operator does not take STRINGs: join them with CONCAT"
                                     : "a STRING compared or combined with a number: convert one of them");
      return constant(0, compare);
    }
    static constexpr BinOp kOrder[] = {BinOp::kEq, BinOp::kNe, BinOp::kLt, BinOp::kLe, BinOp::kGt, BinOp::kGe};
    const double code = static_cast<double>(std::find(std::begin(kOrder), std::end(kOrder), op) - std::begin(kOrder));
    return string_block("scmp", "scmp", pos, {ref(a0, pos), ref(b0, pos)}, {code}, 0);
  }
  if (a0.digital && b0.digital && (logic || op == BinOp::kEq || op == BinOp::kNe)) {
    if (a0.is_const && b0.is_const) {
      const bool x = a0.k != 0, y = b0.k != 0;
      bool r = false;
      switch (op) {
        case BinOp::kAnd: r = x && y; break;
        case BinOp::kOr: r = x || y; break;
        case BinOp::kXor: case BinOp::kNe: r = x != y; break;
        default: r = x == y; break;
      }
      return constant(r ? 1 : 0, true);
    }
    Value r;
    r.digital = true;
    r.ref = fresh("logic");
    const std::string x = ref(a0, pos), y = ref(b0, pos);
    switch (op) {
      case BinOp::kAnd: emit("and", r.ref, pos, {x, y}); break;
      case BinOp::kOr: emit("or", r.ref, pos, {x, y}); break;
      case BinOp::kXor: case BinOp::kNe: emit("exor", r.ref, pos, {x, y}); break;
      default: {
        const std::string e = fresh("xor");
        emit("exor", e, pos, {x, y});
        emit("not", r.ref, pos, {e});
        break;
      }
    }
    return r;
  }
  if (logic) {
    const char* blk = op == BinOp::kAnd ? "band" : op == BinOp::kOr ? "bor" : "bxor";
    if (!has_block(blk)) {
      missing_block(blk, "AND/OR/XOR on integers or bit strings", pos);
      return constant(0, false);
    }
  }
  const Value a = to_analog(a0, pos), b = to_analog(b0, pos);
  const bool integer = a.integer && b.integer;
  if (a.is_const && b.is_const && op != BinOp::kExpt && op != BinOp::kMod &&
      !(op == BinOp::kDiv && b.k == 0) && !logic) {
    double r = 0;
    switch (op) {
      case BinOp::kAdd: r = a.k + b.k; break;
      case BinOp::kSub: r = a.k - b.k; break;
      case BinOp::kMul: r = a.k * b.k; break;
      case BinOp::kDiv: r = integer ? std::trunc(a.k / b.k) : a.k / b.k; break;
      case BinOp::kEq: return constant(a.k == b.k, true);
      case BinOp::kNe: return constant(a.k != b.k, true);
      case BinOp::kLt: return constant(a.k < b.k, true);
      case BinOp::kLe: return constant(a.k <= b.k, true);
      case BinOp::kGt: return constant(a.k > b.k, true);
      case BinOp::kGe: return constant(a.k >= b.k, true);
      default: break;
    }
    Value c = constant(r, false);
    c.integer = integer;
    return c;
  }
  const char* blk = nullptr;
  switch (op) {
    case BinOp::kAdd: blk = "add"; break;
    case BinOp::kSub: blk = "sub"; break;
    case BinOp::kMul: blk = "mult"; break;
    case BinOp::kDiv: blk = "div"; break;
    case BinOp::kMod: blk = "mod"; break;
    case BinOp::kExpt: blk = "expt"; break;
    case BinOp::kAnd: blk = "band"; break;
    case BinOp::kOr: blk = "bor"; break;
    case BinOp::kXor: blk = "bxor"; break;
    case BinOp::kEq: blk = "eq"; break;
    case BinOp::kNe: blk = "ne"; break;
    case BinOp::kLt: blk = "lt"; break;
    case BinOp::kLe: blk = "le"; break;
    case BinOp::kGt: blk = "gt"; break;
    case BinOp::kGe: blk = "ge"; break;
  }
  if (!has_block(blk)) {
    missing_block(blk, std::string("operator ") + blk, pos);
    return constant(0, compare);
  }
  Value r;
  r.digital = compare;
  r.integer = integer && !compare;
  r.ref = fresh(blk);
  emit(blk, r.ref, pos, {ref(a, pos), ref(b, pos)});
  if (op == BinOp::kDiv && integer && has_block("trunc")) {
    Value t;
    t.integer = true;
    t.ref = fresh("trunc");
    emit("trunc", t.ref, pos, {r.ref});
    return t;
  }
  return r;
}

Value Emitter::select(const Value& cond, const Value& a, const Value& b, SourcePos pos) {
  const Value c = to_digital(cond, pos);
  if ((a.str || b.str) && (!(a.str && b.str) || a.wide != b.wide)) {
    d_.error(pos, a.str && b.str ? "a choice between a STRING and a WSTRING" : "a choice between a STRING and a number");
    return a;
  }
  if (c.is_const) return c.k != 0 ? a : b;
  if (a.str || b.str) {
    if (a.is_const && b.is_const && a.text == b.text) return a;
    if (!a.is_const && !b.is_const && a.ref == b.ref) return a;
    // ssel: in0 when g is 0, in1 when it is 1.
    return string_block("ssel", "ssel", pos, {ref(b, pos), ref(a, pos), c.ref},
                             {static_cast<double>(std::max(a.cap, b.cap))}, std::max(a.cap, b.cap), a.wide);
  }
  if (a.is_const && b.is_const && a.k == b.k && a.digital == b.digital) return a;
  if (!a.is_const && !b.is_const && a.ref == b.ref) return a;
  if (a.digital && b.digital && (a.is_const || b.is_const)) {
    // One side known: an AND or an OR (a flow's reasons are mostly constants).
    if (a.is_const && b.is_const) return a.k != 0 ? c : unary_not(c, pos);
    if (a.is_const) return a.k != 0 ? binary(BinOp::kOr, c, b, pos) : binary(BinOp::kAnd, unary_not(c, pos), b, pos);
    return b.k != 0 ? binary(BinOp::kOr, unary_not(c, pos), a, pos) : binary(BinOp::kAnd, c, a, pos);
  }
  if (a.digital && b.digital) {
    Value r;
    r.digital = true;
    r.ref = fresh("sel");
    const std::string t = fresh("sel"), e = fresh("sel"), nc = fresh("sel");
    emit("and", t, pos, {c.ref, ref(a, pos)});
    emit("not", nc, pos, {c.ref});
    emit("and", e, pos, {nc, ref(b, pos)});
    emit("or", r.ref, pos, {t, e});
    return r;
  }
  const Value x = to_analog(a, pos), y = to_analog(b, pos);
  Value r;
  r.integer = x.integer && y.integer;
  r.ref = fresh("sel");
  emit("amux", r.ref, pos, {ref(y, pos), ref(x, pos), c.ref});
  return r;
}

void Emitter::copy_as(const Value& v, const std::string& name, SourcePos pos, uint32_t cap) {
  const std::string x = ref(v, pos);
  if (v.str) {
    emit_flow("scopy", name, pos, {x}, 0, {static_cast<double>(cap != 0 ? cap : v.cap), v.wide ? 1.0 : 0.0});
    return;
  }
  if (v.digital) emit("or", name, pos, {x, x});
  else emit("scale", name, pos, {x}, {1.0, 0.0});
}

Value Emitter::first_cycle(SourcePos pos) {
  if (!first_made_) {
    first_made_ = true;
    ref(constant(0, true), pos);  // plcopen.false, which plcopen.one reads
    emit("not", kFirst, pos, {kOne});  // `one` runs last: 0 only before the first cycle ends
  }
  Value r;
  r.digital = true;
  r.ref = kFirst;
  return r;
}

bool Emitter::finish() {
  if (first_made_) emit("not", kOne, SourcePos{}, {kFalse});
  std::unordered_map<std::string, uint32_t> index;
  for (uint32_t i = 0; i < p_.blocks.size(); ++i) {
    if (!p_.blocks[i].name.empty()) index.emplace(p_.blocks[i].name, i);
  }
  bool ok = true;
  for (size_t i = 0; i < p_.blocks.size(); ++i) {
    FlatBlock& b = p_.blocks[i];
    if (resolved_[i]) continue;
    for (uint32_t k = 0; k < b.n_in; ++k) {
      auto it = index.find(refs_[i][k]);
      if (it == index.end()) {
        d_.error(b.pos, "internal: block " + b.name + " reads '" + refs_[i][k] +
                            "', which the PLCopen lowering never made");
        ok = false;
        continue;
      }
      b.in[k] = it->second;
    }
  }
  for (const auto& [i, names] : tables_) {
    FlatBlock& b = p_.blocks[i];
    b.table.clear();
    for (const std::string& n : names) {
      auto it = index.find(n);
      if (it == index.end()) {
        d_.error(b.pos, "internal: block " + b.name + " indexes '" + n + "', which the PLCopen lowering never made");
        ok = false;
        continue;
      }
      b.table.push_back(it->second);
    }
  }
  return ok;
}

}  // namespace rtplc::lang::plcopen
