// libFuzzer target over the whole front end: source text -> tokens -> AST ->
// checked program -> verified image -> a few executed cycles. Any crash, hang or
// sanitizer report is a bug; diagnostics are the expected outcome of garbage.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "lang/compiler.h"
#include "tests/support/fuzz_compile.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view src(reinterpret_cast<const char*>(data), size);
  rtplc::lang::CompileResult r = rtplc::lang::compile_source(src);
  rtplc::testing::exercise_compile(r, src, "fuzz.fbd");
  return 0;
}
