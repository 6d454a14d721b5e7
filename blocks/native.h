// Native code for a task image (docs/st.md, "Native code"): the verified image
// translated into C++ functions, compiled by the machine's C++ compiler into a
// shared library and loaded, so a loop-heavy program runs at the speed MatIEC's
// and CODESYS's compiled code runs, instead of paying the interpreter's dispatch
// for every instruction of every iteration.
//
// The translation is of the image, not of the source: every language gets it, the
// verifier has already checked every index it writes as a constant, and the
// kernels are the interpreter's own (blocks/kernels.inc, embedded as text), so
// both give the same results bit for bit. Each run becomes straight code with its
// operands as constants; Jmp/Jz/Jnz/Loop become gotos, Loop still counted against
// the cycle's budget. Runs it does not translate (I/O, timers, delay lines,
// strings, long runs the interpreter vectorises) are handed back to the
// interpreter one run at a time.
//
// Compiling takes the compiler's time (milliseconds for a small program, seconds
// for a large one) and happens before a task starts or a swap is made, never in a
// cycle.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "blocks/image.h"
#include "blocks/native_abi.h"
#include "common/result.h"

namespace rtplc {

// How long a compile may take before it is stopped: a 12,000-block program
// takes 30 s on a 2-core VM; slower targets get ten times that.
inline constexpr double kNativeCompileTimeoutS = 300;

struct NativeOptions {
  // The C++ compiler: empty means $RTPLC_CXX, else `c++` from PATH.
  std::string compiler;
  // Where the private build folder is made (and removed): empty means $TMPDIR,
  // else /tmp. It must allow executing the library (not mounted noexec).
  std::string work_dir;
  // A compile that takes longer is stopped and refused (the clients of a swap
  // wait a little longer: sched/control.h kSwapAnswerMs).
  double timeout_s = kNativeCompileTimeoutS;
  // Called about every 100 ms while the compiler runs, on the calling thread
  // (the runtime's control thread goes on with its housekeeping); false stops
  // the compile (the runtime is stopping).
  std::function<bool()> while_waiting;
};

// What the translation made of an image.
struct NativeStats {
  uint32_t native_runs = 0;       // translated
  uint32_t interpreted_runs = 0;  // handed back to the interpreter
  size_t source_bytes = 0;
  double compile_ms = 0;  // the compiler's run (compile_native only)
};

// A loaded library: its entry point runs cycles of exactly the image it was
// compiled from (checked by fingerprint when loaded), while this object lives.
class NativeCode {
 public:
  NativeCode(void* handle, RtplcNativeCycle cycle, uint64_t fingerprint, NativeStats stats)
      : handle_(handle), entry_(cycle), fingerprint_(fingerprint), stats_(stats) {}
  ~NativeCode();
  NativeCode(const NativeCode&) = delete;
  NativeCode& operator=(const NativeCode&) = delete;

  RtplcNativeCycle entry() const { return entry_; }
  // True when this code was compiled from `image` (the same bytes).
  bool compiled_from(const TaskImage& image) const;
  const NativeStats& stats() const { return stats_; }

 private:
  void* handle_;
  RtplcNativeCycle entry_;
  uint64_t fingerprint_;
  NativeStats stats_;
};

// The image's identity for native code: FNV-1a over all its bytes.
uint64_t image_fingerprint(const TaskImage& image);

// The C++ source generated for `image` (what `rtplc compile --native-source` writes).
std::string native_source(const TaskImage& image, NativeStats* stats = nullptr);

// Generates, compiles and loads the native code of `image`. Errors name what
// failed: no compiler, the compiler's own messages, a library that does not load.
Result<std::shared_ptr<const NativeCode>> compile_native(const TaskImage& image,
                                                         const NativeOptions& options = {});

}  // namespace rtplc
