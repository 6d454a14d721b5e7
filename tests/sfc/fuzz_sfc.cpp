// libFuzzer target over the whole SFC front end (docs/sfc.md, "Diagnostics"):
// text -> tokens -> chart -> flat program -> checks -> TaskImage -> a few
// executed cycles, and the same
// text -> hierarchical net. Neither may crash, hang or leak on any input.
#include <cstddef>
#include <cstdint>
#include <string>

#include "blocks/executor.h"
#include "lang/compiler.h"
#include "lang/sfc/lexer.h"
#include "lang/sfc/net_builder.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  std::string text(reinterpret_cast<const char*>(data), size);
  // Keep the compiler on the SFC path: most mutations lose the header.
  if (!rtplc::lang::sfc::starts_with_sfc_keyword(text)) text.insert(0, "SFC f\n");
  rtplc::lang::CompileResult r = rtplc::lang::compile_source(text);
  (void)r.diags.render("f.sfc", text);
  if (r.ok()) {
    (void)rtplc::lang::explain(r);
    rtplc::TaskArena arena(*r.image);
    for (int k = 0; k < 4; ++k) rtplc::execute_cycle(*r.image, arena);
  }
  rtplc::DiagnosticList d;
  auto net = rtplc::lang::sfc::sfc_source_to_net(text, d);
  if (net) (void)rtplc::lang::sfc::render_hierarchy(*net);
  return 0;
}
