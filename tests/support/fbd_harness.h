// Test harness: compile a small FBD body, drive its inputs and set-points by
// label, run cycles and read any block's output by name (F3, F10.M4, ...).
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "blocks/executor.h"
#include "blocks/string_ops.h"
#include "lang/compiler.h"

namespace rtplc::testing {

class FbdHarness {
 public:
  // `body` is the program body only; it is wrapped in "%% ... END".
  explicit FbdHarness(std::string_view body, double dt = 0.1, bool batch = true)
      : FbdHarness(std::string("%%\n") + std::string(body) + "\nEND\n", dt, batch, true) {}

  FbdHarness(const std::string& full_source, double dt, bool batch, bool /*full*/) {
    lang::CompileOptions o;
    o.period_override = dt;
    o.batch = batch;
    result_ = lang::compile_source(full_source, o);
    if (!result_.ok()) {
      ADD_FAILURE() << "program did not compile:\n" << result_.diags.render("test.fbd", full_source);
      return;
    }
    arena_.resize_for(*result_.image);
    for (const Binding& b : result_.image->bindings()) {
      if (b.dir == BindingDir::kSetpoint) arena_.io_in[b.io_index] = b.init;
    }
  }

  bool ok() const { return result_.ok(); }
  const TaskImage& image() const { return *result_.image; }
  TaskArena& arena() { return arena_; }
  const lang::CompileResult& result() const { return result_; }

  // Sets an input or set-point channel by its label.
  void set(std::string_view label, double v) {
    for (const Binding& b : image().bindings()) {
      if (b.dir != BindingDir::kOutput && label == image().str(b.label)) {
        arena_.io_in[b.io_index] = v;
        return;
      }
    }
    ADD_FAILURE() << "no input labelled " << label;
  }
  // Reads an output channel by its label.
  double out(std::string_view label) const {
    for (const Binding& b : image().bindings()) {
      if (b.dir == BindingDir::kOutput && label == image().str(b.label)) return arena_.io_out[b.io_index];
    }
    ADD_FAILURE() << "no output labelled " << label;
    return 0;
  }
  // The current output of the block named `name`.
  double value(std::string_view name) const {
    uint32_t i = index_of(name);
    return arena_.values[image().code()[i].out];
  }
  // The text of the STRING block named `name` (docs/st.md, "Strings").
  std::string text(std::string_view name) const {
    uint32_t i = index_of(name);
    const Instr& in = image().code()[i];
    return string_value(arena_.values.data(), static_cast<uint32_t>(arena_.values.size()), in.out,
                        writes_wide_string(in, image().params().data() + in.param));
  }
  uint64_t errors(std::string_view name) const { return arena_.errors[index_of(name)]; }

  void step(int n = 1) {
    for (int k = 0; k < n; ++k) execute_cycle(image(), arena_);
  }

 private:
  uint32_t index_of(std::string_view name) const {
    auto blocks = image().blocks();
    for (uint32_t i = 0; i < blocks.size(); ++i) {
      if (name == image().str(blocks[i].name)) return i;
    }
    ADD_FAILURE() << "no block named " << name;
    return 0;
  }

  lang::CompileResult result_;
  TaskArena arena_;
};

// Compiles and returns the rendered diagnostics (empty if none).
inline std::string diagnostics_of(const std::string& source, bool* ok = nullptr) {
  lang::CompileResult r = lang::compile_source(source);
  if (ok) *ok = r.ok();
  return r.diags.render("t.fbd", source);
}

// Two analog set-points a, b and three digital ones x, y, z (F1, F2, D3, D4,
// D5) that a block test drives with set_point(); with_inputs() puts them before
// the blocks under test.
inline constexpr const char* kSetpointInputs =
    "F1 = asp(d0, c0, 0, \"a\")\n"
    "F2 = asp(d0, c1, 0, \"b\")\n"
    "D3 = dsp(d0, c2, 0, \"x\")\n"
    "D4 = dsp(d0, c3, 0, \"y\")\n"
    "D5 = dsp(d0, c4, 0, \"z\")\n";

inline FbdHarness with_inputs(const std::string& body, double dt = 0.1) {
  return FbdHarness(std::string(kSetpointInputs) + body, dt);
}

// One cycle of a program (any language) with a loop budget of 1,000: the
// block whose loop ran past it, or nullptr when none did.
inline const BlockInfo* runaway_loop_in(FbdHarness& h) {
  h.arena().loop_budget = 1000;
  h.step();
  return h.arena().loop_fault == 0 ? nullptr : &h.image().blocks()[h.arena().loop_fault - 1];
}

}  // namespace rtplc::testing
