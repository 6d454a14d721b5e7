// libFuzzer target over the whole front end: source text -> tokens -> AST ->
// checked program -> verified image -> a few executed cycles. Any crash, hang or
// sanitizer report is a bug; diagnostics are the expected outcome of garbage.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "blocks/executor.h"
#include "lang/compiler.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view src(reinterpret_cast<const char*>(data), size);
  rtplc::lang::CompileResult r = rtplc::lang::compile_source(src);
  if (r.ok()) {
    (void)rtplc::lang::explain(r);
    rtplc::TaskArena arena(*r.image);
    for (int i = 0; i < 3; ++i) rtplc::execute_cycle(*r.image, arena);
    // The image must survive a trip through bytes.
    auto back = rtplc::TaskImage::from_bytes(r.image->bytes());
    if (!back.ok()) __builtin_trap();
  } else if (!r.diags.has_errors()) {
    __builtin_trap();  // failing without saying why is a bug too
  }
  (void)r.diags.render("fuzz.fbd", src);
  return 0;
}
