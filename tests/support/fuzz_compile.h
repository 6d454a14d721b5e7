// What every compiler fuzz target (fuzz_frontend, fuzz_plcopen, fuzz_st) asks
// of one compile: a program that compiled explains itself, runs a few cycles
// and survives a trip of its image through bytes; one that did not says why.
// A crash, hang or sanitizer report is a bug; diagnostics are the expected
// outcome of garbage.
#pragma once

#include <string_view>

#include "blocks/executor.h"
#include "lang/compiler.h"

namespace rtplc::testing {

inline void exercise_compile(const lang::CompileResult& r, std::string_view src, const char* name) {
  if (r.ok()) {
    (void)lang::explain(r);
    TaskArena arena(*r.image);
    arena.loop_budget = 1000;  // a runaway loop ends each cycle quickly (and must end it)
    for (int i = 0; i < 3; ++i) execute_cycle(*r.image, arena);
    if (!TaskImage::from_bytes(r.image->bytes()).ok()) __builtin_trap();
  } else if (!r.diags.has_errors()) {
    __builtin_trap();  // failing without saying why is a bug too
  }
  (void)r.diags.render(name, src);
}

}  // namespace rtplc::testing
