// The interface between rtplc and the native code it generates for a task image
// (blocks/native.h, docs/st.md "Native code"). This header is compiled into rtplc
// and, as text, into every generated library, so both sides read one layout.
// Plain C types only: the library is loaded with dlopen and called through one
// extern "C" entry point.
#pragma once

#include <cstdint>

// Raised whenever this layout or the generated code's conventions change; a
// library built for another value is refused at load.
#define RTPLC_NATIVE_ABI 1

extern "C" {

// What one cycle of native code works on; built by the executor each cycle from
// its ExecContext (blocks/executor.h), no allocation.
struct RtplcNativeFrame {
  const double* params;  // the image's prepared parameter pool (read only)
  double* values;
  double* state;
  uint64_t* errors;      // per instruction, schedule order
  uint64_t loop_budget;  // backward branches allowed this cycle
  uint32_t* loop_fault;  // may be null; 1 + the Loop's index when the budget ran out
  // Runs run `run` of the image on the interpreter and returns the failures it
  // counted: the native code hands back every run it does not compile itself
  // (I/O, timers, strings, long vectorisable runs).
  uint64_t (*interpret)(const void* context, uint32_t run);
  const void* context;
};

// The entry point: runs the cycle's program and returns the failures to add to
// the task's count. Never allocates, locks, throws or makes a system call.
typedef uint64_t (*RtplcNativeCycle)(const RtplcNativeFrame* frame);

}  // extern "C"
