// libFuzzer target over the PLCopen importer: XML -> project -> lowered flat
// program -> checks -> verified image -> a few executed cycles. A crash, hang
// or sanitizer report is a bug; diagnostics are the expected outcome of garbage.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "lang/compiler.h"
#include "lang/plcopen/import.h"
#include "tests/support/fuzz_compile.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view src(reinterpret_cast<const char*>(data), size);
  rtplc::lang::CompileResult r = rtplc::lang::compile_source(src);
  if (!rtplc::lang::plcopen::is_plcopen_source(src)) {
    // Reach the importer even when the mutation broke the root's name.
    rtplc::DiagnosticList d;
    (void)rtplc::lang::plcopen::import_plcopen(src, {}, d);
    return 0;
  }
  rtplc::testing::exercise_compile(r, src, "fuzz.xml");
  return 0;
}
