// libFuzzer target over the runtime configuration loader (config/config.h):
// YAML text -> diagnostics or a RuntimeConfig. Any crash, hang, sanitizer
// report or escaped exception is a bug; diagnostics are the expected outcome
// of garbage. Seeds: tests/config/corpus/.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "config/config.h"
#include "io/drivers/sim/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view text(reinterpret_cast<const char*>(data), size);
  rtplc::config::LoadOptions opt;
  opt.check_program_files = false;  // the disk is not what is under test
  rtplc::config::LoadResult r = rtplc::config::parse_config(text, "fuzz.yaml", "/plant", opt);
  if (r.config.has_value() == r.diags.has_errors()) __builtin_trap();  // ok() must be exact
  if (r.config) {
    // What the loader promises the runtime about a config it accepted.
    const auto& c = *r.config;
    if (c.tasks.empty() || c.tasks.size() > 16) __builtin_trap();
    if (c.band_lo < 1 || c.band_lo > c.band_hi || c.band_hi > 98) __builtin_trap();
    for (const auto& t : c.tasks) {
      if (t.name.empty() || t.program.empty()) __builtin_trap();
      if (t.priority && (*t.priority < c.band_lo || *t.priority > c.band_hi)) __builtin_trap();
      if (t.period_s && !(*t.period_s >= 9.99e-6 && *t.period_s <= 3600.0001)) __builtin_trap();
    }
    for (const auto& d : c.drivers) {
      if (d.name.empty() || d.kind.empty()) __builtin_trap();
      if (d.kind == "sim" && sim::settings_of(d).plants.empty()) __builtin_trap();
    }
  }
  (void)r.render();
  return 0;
}
