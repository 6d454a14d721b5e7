// The standard's string functions and conversions (docs/st.md, "Strings"):
// LEN, LEFT, RIGHT, MID, CONCAT, INSERT, DELETE, REPLACE, FIND, SEL, MOVE and
// the comparisons EQ .. GE on strings, X_TO_STRING, TO_STRING and STRING_TO_X,
// each lowered to the
// string blocks (blocks/string_ops.h).
#include <algorithm>

#include "blocks/string_ops.h"
#include "lang/iec/iec_functions.h"
#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {
namespace {

struct StringFunction {
  const char* name;
  std::vector<const char*> formals;  // in order; CONCAT takes IN1 .. INn
  bool extensible = false;
};

const std::vector<StringFunction>& string_functions() {
  static const std::vector<StringFunction> fs = {
      {"LEN", {"IN"}},
      {"LEFT", {"IN", "L"}},
      {"RIGHT", {"IN", "L"}},
      {"MID", {"IN", "L", "P"}},
      {"CONCAT", {"IN1", "IN2"}, true},
      {"INSERT", {"IN1", "IN2", "P"}},
      {"DELETE", {"IN", "L", "P"}},
      {"REPLACE", {"IN1", "IN2", "L", "P"}},
      {"FIND", {"IN1", "IN2"}},
  };
  return fs;
}

const StringFunction* find_string_function(const std::string& up) {
  for (const StringFunction& f : string_functions()) {
    if (up == f.name) return &f;
  }
  return nullptr;
}

// The text format of an elementary type's value (blocks/string_ops.h).
std::optional<StringFormat> format_of(BaseType b) {
  switch (b) {
    case BaseType::kBool: return StringFormat::kBool;
    case BaseType::kSint: case BaseType::kInt: case BaseType::kDint: case BaseType::kLint:
      return StringFormat::kSigned;
    case BaseType::kUsint: case BaseType::kUint: case BaseType::kUdint: case BaseType::kUlint:
      return StringFormat::kUnsigned;
    case BaseType::kByte: case BaseType::kWord: case BaseType::kDword: case BaseType::kLword:
      return StringFormat::kBits;
    case BaseType::kReal: return StringFormat::kReal;
    case BaseType::kLreal: return StringFormat::kLreal;
    case BaseType::kTime: return StringFormat::kTime;
    case BaseType::kDate: return StringFormat::kDate;
    case BaseType::kTod: return StringFormat::kTod;
    case BaseType::kDt: return StringFormat::kDt;
    default: return std::nullopt;
  }
}

// The type a TO_STRING argument has, as far as the lowering knows it.
BaseType type_of_value(const Value& v) {
  if (v.digital) return BaseType::kBool;
  if (v.time_type) return static_cast<BaseType>(*v.time_type);
  if (v.int_type) return static_cast<BaseType>(*v.int_type);
  return v.integer ? BaseType::kLint : BaseType::kLreal;
}

constexpr uint32_t kNumberText = 64;  // the longest text a number converts to, and some
constexpr unsigned long kMaxConcatInputs = 100;  // CONCAT(IN1 := ..., IN100 := ...)

}  // namespace

uint32_t Lowering::default_string_length() const { return semantics_ == EditorSemantics::kCodesys ? 80 : 126; }

std::optional<Value> Lowering::call_string_function(const std::string& up, const std::vector<Value>& args,
                                                    const std::vector<std::string>& formals, SourcePos pos) {
  const double dialect = semantics_ == EditorSemantics::kCodesys ? 1.0 : 0.0;
  const size_t to = up.find("_TO_");
  const bool any_string = std::any_of(args.begin(), args.end(), [](const Value& v) { return v.str; });
  // ---- conversions ----
  // X_TO_STRING, TO_STRING, X_TO_WSTRING, TO_WSTRING (X a number, or the
  // other string type).
  const bool to_wide = up == "TO_WSTRING" || (to != std::string::npos && up.compare(to + 4, std::string::npos, "WSTRING") == 0);
  if (to_wide || up == "TO_STRING" || (to != std::string::npos && up.compare(to + 4, std::string::npos, "STRING") == 0)) {
    if (args.size() != 1) {
      d_.error(pos, up + " takes 1 argument, found " + std::to_string(args.size()));
      return string_constant("", to_wide);
    }
    const std::string from_name = to == std::string::npos ? "" : up.substr(0, to);  // "" for TO_...
    if (args[0].str) {
      const bool from_wide = args[0].wide;
      if (!from_name.empty() && from_name != (from_wide ? "WSTRING" : "STRING")) {
        d_.error(pos, up + " takes a " + from_name + ", not a " + (from_wide ? "WSTRING" : "STRING"));
        return string_constant("", to_wide);
      }
      if (from_wide == to_wide) return args[0];
      // Between STRING and WSTRING: a byte is the code unit of the same number;
      // a code unit above 255 is '?' in a STRING.
      return em_.string_block("scopy", "scopy", pos, {em_.ref(args[0], pos)},
                                   {static_cast<double>(args[0].cap), to_wide ? 1.0 : 0.0}, args[0].cap, to_wide);
    }
    BaseType from = type_of_value(args[0]);
    if (!from_name.empty()) {
      const auto b = elementary_type(from_name);
      if (!b || !format_of(*b)) {
        d_.error(pos, "conversion " + up + " names a type rtplc does not have");
        return string_constant("", to_wide);
      }
      from = *b;
    }
    const Value x = em_.to_analog(args[0], pos);
    return em_.string_block("sfmt", "sfmt", pos, {em_.ref(x, pos)},
                                 {static_cast<double>(kNumberText), static_cast<double>(*format_of(from)), dialect},
                                 kNumberText, to_wide);
  }
  const bool from_wide = up.rfind("WSTRING_TO_", 0) == 0;
  if (from_wide || up.rfind("STRING_TO_", 0) == 0) {
    const std::string into = up.substr(from_wide ? 11 : 10);
    const auto b = elementary_type(into);
    if (!b || !format_of(*b)) {
      d_.error(pos, "conversion " + up + " names a type rtplc does not have");
      return constant(0, false);
    }
    if (args.size() != 1 || !args[0].str || args[0].wide != from_wide) {
      d_.error(pos, up + " takes 1 " + (from_wide ? "WSTRING" : "STRING"));
      return constant(0, *b == BaseType::kBool);
    }
    Value r = em_.string_block("sparse", "sparse", pos, {em_.ref(args[0], pos)},
                               {static_cast<double>(*format_of(*b)), dialect}, 0);
    if (*b == BaseType::kBool) return em_.to_digital(r, pos);
    const iec::IecTypeInfo& t = iec::type_info(iec_type(*b));
    if (t.integer) {
      // Wrapped into the type, as every integer conversion is (STRING_TO_BYTE('500') is 244).
      Value w;
      w.ref = em_.fresh("wrap");
      em_.emit("wrap", w.ref, pos, {r.ref}, {static_cast<double>(t.bits), t.is_signed ? 1.0 : 0.0});
      w.integer = true;
      w.int_type = iec_type(*b);
      return w;
    }
    if (iec::time_grid(iec_type(*b)) != 0) r.time_type = iec_type(*b);
    return r;
  }
  // ---- SEL and MOVE on strings ----
  if (any_string && (up == "SEL" || up == "MOVE")) {
    const bool sel = up == "SEL";
    if (args.size() != (sel ? 3u : 1u) || !args[sel ? 1 : 0].str || (sel && !args[2].str)) {
      d_.error(pos, sel ? "SEL on strings takes G, IN0 and IN1, both STRINGs" : "MOVE takes 1 argument");
      return string_constant("");
    }
    return sel ? em_.select(args[0], args[2], args[1], pos) : args[0];
  }
  // ---- comparisons called as functions: EQ(a, b), GT(a, b, c) = a > b AND b > c ----
  static const std::pair<const char*, BinOp> kCompare[] = {{"EQ", BinOp::kEq}, {"NE", BinOp::kNe},
                                                           {"LT", BinOp::kLt}, {"LE", BinOp::kLe},
                                                           {"GT", BinOp::kGt}, {"GE", BinOp::kGe}};
  for (const auto& [name, op] : kCompare) {
    if (!any_string || up != name) continue;
    const bool ne = op == BinOp::kNe;
    if (args.size() < 2 || (ne && args.size() != 2)) {
      d_.error(pos, up + " takes " + (ne ? "2" : "at least 2") + " arguments, found " + std::to_string(args.size()));
      return constant(0, true);
    }
    Value r = em_.binary(op, args[0], args[1], pos);
    for (size_t k = 2; k < args.size(); ++k) {
      r = em_.binary(BinOp::kAnd, r, em_.binary(op, args[k - 1], args[k], pos), pos);
    }
    return r;
  }
  // ---- the string functions ----
  const StringFunction* f = find_string_function(up);
  if (f == nullptr) return std::nullopt;
  std::vector<std::optional<Value>> placed;
  size_t positional = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string formal = i < formals.size() ? upper(formals[i]) : "";
    size_t k = 0;
    if (formal.empty()) {
      while (positional < placed.size() && placed[positional]) ++positional;
      k = positional;
    } else {
      const auto it = std::find_if(f->formals.begin(), f->formals.end(), [&](const char* n) { return formal == n; });
      if (it != f->formals.end()) {
        k = static_cast<size_t>(it - f->formals.begin());
      } else if (f->extensible && formal.size() > 2 && formal.size() <= 5 && formal.compare(0, 2, "IN") == 0 &&
                 formal.find_first_not_of("0123456789", 2) == std::string::npos &&
                 std::stoul(formal.substr(2)) >= 1 && std::stoul(formal.substr(2)) <= kMaxConcatInputs) {
        // IN1 .. IN<kMaxConcatInputs> (at most three digits, so stoul cannot fail)
        k = std::stoul(formal.substr(2)) - 1;
      } else {
        d_.error(pos, up + " has no input '" + formals[i] + "'");
        return string_constant("");
      }
    }
    if (k >= f->formals.size() && !f->extensible) {
      d_.error(pos, up + " takes " + std::to_string(f->formals.size()) + " arguments, found " +
                        std::to_string(args.size()));
      return string_constant("");
    }
    if (placed.size() <= k) placed.resize(k + 1);
    if (placed[k]) {
      d_.error(pos, up + "'s " + (k < f->formals.size() ? std::string(f->formals[k]) : "IN" + std::to_string(k + 1)) +
                        " is given twice");
      return string_constant("");
    }
    placed[k] = args[i];
  }
  const size_t need = f->formals.size();
  if (placed.size() < need || std::any_of(placed.begin(), placed.end(), [](const auto& a) { return !a; })) {
    d_.error(pos, up + " takes " + (f->extensible ? "at least " : "") + std::to_string(need) + " arguments (" +
                      [&] {
                        std::string n;
                        for (const char* x : f->formals) n += (n.empty() ? "" : ", ") + std::string(x);
                        return n;
                      }() + (f->extensible ? ", ..." : "") + ")");
    return string_constant("");
  }
  // IN, IN1, IN2 (and CONCAT's every input) are STRINGs, or all WSTRINGs; L and P numbers.
  const bool wide = placed[0]->wide;
  for (size_t k = 0; k < placed.size(); ++k) {
    const bool wants_string = k >= f->formals.size() || f->formals[k][0] == 'I';
    const std::string formal = k < f->formals.size() ? f->formals[k] : "IN" + std::to_string(k + 1);
    if (placed[k]->str != wants_string) {
      d_.error(pos, up + "'s " + formal + (wants_string ? " is a STRING" : " is a number (a count or a position)"));
      return string_constant("", wide);
    }
    if (wants_string && placed[k]->wide != wide) {
      d_.error(pos, up + " mixes a STRING and a WSTRING (" + formal + "): convert one (STRING_TO_WSTRING, WSTRING_TO_STRING)");
      return string_constant("", wide);
    }
  }
  auto s = [&](size_t k) { return em_.ref(*placed[k], pos); };
  auto n = [&](size_t k) { return em_.ref(em_.to_analog(*placed[k], pos), pos); };
  // A result that joins two strings holds what both do, at most the editor's
  // longest (MatIEC 126, CODESYS 255) unless an argument is longer still.
  const uint32_t limit = semantics_ == EditorSemantics::kCodesys ? 255 : 126;
  auto joined = [&](uint32_t a, uint32_t b) { return std::min(a + b, std::max({limit, a, b})); };
  const std::string stem = "s" + std::string(f->name);
  if (up == "LEN") return em_.string_block("slen", stem, pos, {s(0)}, {}, 0);
  if (up == "FIND") return em_.string_block("sfind", stem, pos, {s(0), s(1)}, {}, 0);
  const uint32_t cap0 = placed[0]->cap;
  auto block = [&](const char* written, std::vector<std::string> ins, uint32_t cap) {
    return em_.string_block(written, stem, pos, std::move(ins), {static_cast<double>(cap)}, cap, wide);
  };
  if (up == "LEFT" || up == "RIGHT") return block(up == "LEFT" ? "sleft" : "sright", {s(0), n(1)}, cap0);
  if (up == "MID") return block("smid", {s(0), n(1), n(2)}, cap0);
  if (up == "DELETE") return block("sdel", {s(0), n(1), n(2)}, cap0);
  if (up == "INSERT") return block("sins", {s(0), s(1), n(2)}, joined(cap0, placed[1]->cap));
  if (up == "REPLACE") {
    // The standard's: IN2 in place of L characters from position P, as
    // DELETE then INSERT after position P - 1. (MatIEC inserts only the first
    // L characters of IN2; docs/st.md says why rtplc does not.)
    const Value del = block("sdel", {s(0), n(2), n(3)}, cap0);
    const Value at = em_.binary(BinOp::kSub, em_.to_analog(*placed[3], pos), constant(1, false), pos);
    return block("sins", {del.ref, s(1), em_.ref(at, pos)}, joined(cap0, placed[1]->cap));
  }
  // CONCAT: left to right.
  Value acc = *placed[0];
  for (size_t k = 1; k < placed.size(); ++k) {
    acc = block("scat", {em_.ref(acc, pos), s(k)}, joined(acc.cap, placed[k]->cap));
  }
  return acc;
}

}  // namespace rtplc::lang::plcopen
