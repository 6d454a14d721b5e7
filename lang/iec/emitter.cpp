// The block emitter (lang/iec/emitter.h).
#include "lang/iec/emitter.h"

#include <cstdio>

namespace rtplc::lang::iec {

Emitter::Emitter(CheckedProgram& program, std::string prefix, SourcePos pos, uint32_t call_line)
    : program_(program),
      prefix_(std::move(prefix)),
      pos_(pos),
      call_line_(call_line != 0 ? call_line : (pos.line != 0 ? pos.line : 1)) {}

std::string Emitter::next_name(std::string_view role) {
  auto it = used_roles_.find(role);
  std::string r(role);
  if (it == used_roles_.end()) {
    used_roles_.emplace(r, 1);
  } else {
    r += std::to_string(++it->second);
  }
  return prefix_.empty() ? r : prefix_ + "." + r;
}

uint32_t Emitter::block(std::string_view primitive, std::initializer_list<uint32_t> inputs,
                        std::initializer_list<double> params, std::string_view role) {
  FlatBlock b;
  b.written = std::string(primitive);
  b.name = next_name(role.empty() ? primitive : role);
  b.pos = pos_;
  b.call_line = call_line_;
  for (uint32_t in : inputs) {
    if (b.n_in < 3) {
      b.in[b.n_in] = in;
      b.in_pos[b.n_in] = pos_;
    }
    ++b.n_in;  // more than 3 is reported as wrong arity by the checks
  }
  b.params.assign(params.begin(), params.end());
  program_.blocks.push_back(std::move(b));
  return static_cast<uint32_t>(program_.blocks.size() - 1);
}

uint32_t Emitter::constant(double v, Kind kind) {
  const auto key = std::make_pair(v, static_cast<int>(kind));
  if (auto it = constants_.find(key); it != constants_.end()) return it->second;
  const uint32_t i =
      kind == Kind::kAnalog ? block("const", {}, {v}, "k") : block("dconst", {}, {v}, "kd");
  constants_.emplace(key, i);
  return i;
}

uint32_t Emitter::external(Kind kind) {
  externals_.push_back(kind);
  return kExternalBase + static_cast<uint32_t>(externals_.size() - 1);
}

Kind Emitter::kind_of(uint32_t producer) const {
  if (is_external(producer)) {
    const size_t slot = external_slot(producer);
    return slot < externals_.size() ? externals_[slot] : Kind::kAnalog;
  }
  if (producer >= program_.blocks.size()) return Kind::kAnalog;
  const FlatBlock& b = program_.blocks[producer];
  const BlockSpec* s = b.spec != nullptr ? b.spec : find_block(b.written);
  return s != nullptr ? s->out_kind : Kind::kAnalog;
}

uint32_t Emitter::analog(uint32_t p) {
  return kind_of(p) == Kind::kDigital ? block("d2a", {p}) : p;
}

uint32_t Emitter::digital(uint32_t p) {
  return kind_of(p) == Kind::kAnalog ? block("a2d", {p}) : p;
}

uint32_t Emitter::analog_or_zero(uint32_t p) {
  return p == kUnconnected ? constant(0, Kind::kAnalog) : analog(p);
}

uint32_t Emitter::digital_or_false(uint32_t p) {
  return p == kUnconnected ? constant(0, Kind::kDigital) : digital(p);
}

uint32_t Emitter::wrap(uint32_t p, IecType t) {
  const IecTypeInfo& ti = type_info(t);
  if (t == IecType::kBool) return digital(p);
  if (!ti.integer) return analog(p);
  return block("wrap", {analog(p)}, {static_cast<double>(ti.bits), ti.is_signed ? 1.0 : 0.0});
}

uint32_t Emitter::convert(uint32_t p, IecType from, IecType to) {
  const IecTypeInfo& f = type_info(from);
  const IecTypeInfo& t = type_info(to);
  if (to == IecType::kBool) return digital(p);
  uint32_t v = analog(p);
  const bool from_time = time_grid(from) != 0, to_time = time_grid(to) != 0;
  if (from_time && to_time) return v;  // one type: the table has no other pair
  if (from_time || to_time) {
    // rtplc keeps every time type in seconds. A time type meets a number in
    // MatIEC's seconds (its __int_to_time makes seconds, __time_to_int returns
    // tv_sec: the fraction dropped), or in CODESYS's units: milliseconds for
    // TIME and TOD, seconds for DATE and DT (docs/st.md, "Dates and times of day").
    const IecType time_type = from_time ? from : to;
    const bool ms = !matiec_ && (time_type == IecType::kTime || time_type == IecType::kTod);
    if (to_time) return ms ? block("scale", {v}, {0.001, 0.0}) : v;
    if (ms) v = block("scale", {v}, {1000.0, 0.0});
    if (!t.integer) return v;
    return wrap(block(matiec_ ? "trunc" : "round", {v}), to);
  }
  if (from == IecType::kBool) return v;  // 0 or 1 fits every type
  if (!t.integer) return v;
  const bool from_real = !f.integer;  // REAL, LREAL
  // MatIEC's __real_to_uint: a negative value becomes 0, not a wrapped one.
  if (from_real && matiec_ && !t.is_signed) v = block("max", {v, constant(0, Kind::kAnalog)});
  if (from_real) v = block("round", {v});
  if (!from_real && range_contains(t, f)) return v;
  return wrap(v, to);
}

}  // namespace rtplc::lang::iec
