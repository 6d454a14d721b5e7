// The registry of I/O driver kinds the configuration knows (spec io-links.md,
// "Where data comes from"; runtime.md, "Configuration"). Each kind brings its
// own key tables (for the unknown-key checks and docs/config.md) and a parser
// that fills a DriverConfig from its YAML map. Adding a kind (s7, modbus, gpio,
// can) is one new driver_<kind>.cpp and one row in driver_kinds.cpp; the loader,
// the schema and the docs generator pick it up from here.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "config/config.h"
#include "config/schema.h"

namespace rtplc::config {

class YamlReader;
class Fields;

struct DriverKind {
  const char* kind;     // what `kind:` says
  const char* summary;  // one line for the docs and the unknown-kind message
  // Keys this kind adds to a driver's map, beside driver_section()'s.
  const SectionSpec* keys;
  // Further sections of the kind's docs (e.g. the sim driver's plant entries).
  std::span<const SectionSpec* const> subsections;
  // Reads the kind's own keys from the driver's map, already checked against
  // driver_section() and `keys` (unknown, duplicate, missing keys), into `out`;
  // reports bad values through `r`.
  void (*parse)(YamlReader& r, const Fields& fields, DriverConfig& out);
  // Markdown for docs/config.md after the kind's tables (may return "").
  std::string (*doc)();
};

std::span<const DriverKind* const> driver_kinds();
const DriverKind* find_driver_kind(std::string_view kind);
// "sim" or "sim, modbus": for "expected one of ..." messages.
std::string known_driver_kinds();

// The kinds' own tables (defined in driver_<kind>.cpp).
extern const DriverKind kSimDriverKind;
extern const DriverKind kS7DriverKind;

}  // namespace rtplc::config
