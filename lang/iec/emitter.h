// Appends primitive blocks to a flat program (lang/flat_program.h) for a front
// end that lowers IEC 61131-3 calls: the PLCopen importer and anything else
// that builds a CheckedProgram. It never checks: check_flat_program() does that
// for every front end alike, so an emitter mistake is reported like a user's.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "lang/flat_program.h"
#include "lang/iec/iec_types.h"

namespace rtplc::lang::iec {

// An input that is not connected: the lowering uses the IEC default (0 / FALSE).
inline constexpr uint32_t kUnconnected = UINT32_MAX;

class Emitter {
  static constexpr uint32_t kExternalBase = 0x80000000u;

 public:
  // Blocks are named `prefix + "." + role` ("main.T1.Q"), which hot swap matches
  // state by, so a stable prefix (the instance path) keeps state across edits.
  // `call_line` 0 means "the call's own line": lowered blocks count as inside a
  // call, so an unread helper (an ET nobody wires) is not reported as unused.
  Emitter(CheckedProgram& program, std::string prefix, SourcePos pos, uint32_t call_line = 0);

  // One primitive block (`written` = a registry name); returns its index.
  // `role` names it; empty: the primitive's name, numbered when repeated.
  uint32_t block(std::string_view primitive, std::initializer_list<uint32_t> inputs,
                 std::initializer_list<double> params = {}, std::string_view role = {});

  // A constant (one block per value and kind within this emitter).
  uint32_t constant(double v, Kind kind);

  // The producer as the other kind, adding d2a / a2d when needed.
  uint32_t analog(uint32_t producer);
  uint32_t digital(uint32_t producer);
  // kUnconnected becomes the default constant of that kind.
  uint32_t analog_or_zero(uint32_t producer);
  uint32_t digital_or_false(uint32_t producer);

  // The value kept in `t`'s range (wrap for integer types, else unchanged).
  uint32_t wrap(uint32_t producer, IecType t);
  // A `*_TO_*` conversion (docs/language.md says which rounding and scaling).
  uint32_t convert(uint32_t producer, IecType from, IecType to);
  // Whose conversions: CODESYS's (the default) or MatIEC's. They differ where
  // TIME meets numbers: milliseconds (CODESYS: TIME_TO_DINT(T#1.5s) = 1500) or
  // whole seconds (MatIEC: TIME_TO_DINT(T#1.5s) = 1, DINT_TO_TIME(2) = T#2s,
  // TIME_TO_REAL = seconds); and for a negative REAL into an unsigned type or a
  // bit string, which MatIEC's __real_to_uint makes 0 (CODESYS's wraps).
  void set_matiec_conversions(bool on) { matiec_ = on; }

  // An operand the front end has not made as a block yet: the PLCopen importer
  // names its producers and resolves the names once every block exists, so a
  // value may come from a block appended later (last cycle's value). Returns a
  // stand-in index past every block; the front end rewrites the inputs that
  // hold it after the lowering (is_external, external_slot).
  uint32_t external(Kind kind);
  static bool is_external(uint32_t producer) {
    return producer >= kExternalBase && producer != kUnconnected;
  }
  static size_t external_slot(uint32_t producer) { return producer - kExternalBase; }

  Kind kind_of(uint32_t producer) const;
  CheckedProgram& program() { return program_; }

 private:
  std::string next_name(std::string_view role);

  CheckedProgram& program_;
  std::string prefix_;
  SourcePos pos_;
  uint32_t call_line_;
  bool matiec_ = false;
  std::map<std::string, uint32_t, std::less<>> used_roles_;
  std::map<std::pair<double, int>, uint32_t> constants_;
  std::vector<Kind> externals_;
};

}  // namespace rtplc::lang::iec
