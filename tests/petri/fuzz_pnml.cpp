// libFuzzer target for the PNML reader (issue item 7): any bytes must give a net
// or diagnostics, never a crash, a hang or unbounded memory. A net that reads is
// also written and read again, and must come back the same size.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "lang/petri/pnml.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  rtplc::petri::PnmlReadResult r = rtplc::petri::read_pnml(text);
  if (r.net) {
    const rtplc::petri::PnmlReadResult again =
        rtplc::petri::read_pnml(rtplc::petri::write_pnml(*r.net));
    if (!again.net || again.net->place_count() != r.net->place_count() ||
        again.net->transition_count() != r.net->transition_count() ||
        again.net->arc_count() != r.net->arc_count()) {
      std::abort();
    }
  }
  return 0;
}
