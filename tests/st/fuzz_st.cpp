// libFuzzer target over the ST front end: a textual file -> the project model ->
// lowered flat program -> checks -> verified image -> a few executed cycles.
// A crash, hang or sanitizer report is a bug; diagnostics are the expected
// outcome of garbage. Seeds: tests/st/corpus (and examples/tank_pump.st).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "lang/compiler.h"
#include "lang/st/st_file.h"
#include "tests/support/fuzz_compile.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view src(reinterpret_cast<const char*>(data), size);
  rtplc::lang::CompileOptions o;
  o.name = "fuzz.st";
  // As a .st file whatever its first word: the reader sees every mutation.
  const rtplc::lang::CompileResult r = rtplc::lang::compile_source(
      rtplc::lang::st::is_st_source(src) ? std::string(src) : "PROGRAM fuzz\n" + std::string(src), o);
  rtplc::testing::exercise_compile(r, src, "fuzz.st");
  return 0;
}
