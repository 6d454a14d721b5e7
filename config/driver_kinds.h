// The configuration side of a driver kind (spec io-links.md, "Where data comes
// from"; runtime.md, "Configuration"): the keys a kind adds to a driver's map
// (for the unknown-key checks and docs/config.md), the parser that fills a
// DriverConfig from them, and the channels a driver of that kind provides and
// consumes. Each kind's table lives in its own folder under io/drivers/ (with
// the runtime side, see io/drivers/driver.h) and reaches this registry through
// io/drivers/registry.cpp; the loader, the schema and the docs generator take
// the kinds from here and never name one.
#pragma once

#include <any>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.h"
#include "config/schema.h"

namespace rtplc::config {

class YamlReader;
class Fields;

// One channel a driver exchanges with the tasks, named by its channel key
// (blocks/image.h channel_key(): "in/DIO/p0.d0.c0", "out/ETH/p1.d0.c1").
struct ChannelClaim {
  std::string key;
  std::string label;  // how messages and the monitor name it when no program does: "plant.p0.d0.c0"
  SourcePos pos;      // the config entry that makes the claim
  // Inputs: the age after which the driver no longer vouches for a good value
  // (io::judge_quality), e.g. three polls of its peer; 0 lets the runtime use
  // three driver periods. The driver's `max_age:` key overrides both.
  int64_t max_age_ns = 0;
};

// What a driver exchanges, derived from its parsed settings alone.
struct DriverClaims {
  std::vector<ChannelClaim> provides;  // inputs it writes, in the order of its image region
  std::vector<ChannelClaim> consumes;  // task outputs it sends (each must have a writer task)
  uint32_t links = 0;                  // rows of the image's link table it reports (peers)
};

// A driver's parsed settings as its kind's type (the kind's parser stored them
// in DriverConfig::settings); an empty default for a driver of another kind.
// Each kind's settings_of() is this, for its own type.
template <class Settings>
const Settings& settings_as(const DriverConfig& d) {
  static const Settings kNone;
  const auto* s = std::any_cast<Settings>(&d.settings);
  return s ? *s : kNone;
}

struct DriverKind {
  const char* kind;     // what `kind:` says
  const char* summary;  // one line for the docs and the unknown-kind message
  // Keys this kind adds to a driver's map, beside driver_section()'s.
  const SectionSpec* keys;
  // Further sections of the kind's docs (e.g. the sim driver's plant entries).
  std::span<const SectionSpec* const> subsections;
  // Reads the kind's own keys from the driver's map, already checked against
  // driver_section() and `keys` (unknown, duplicate, missing keys), into `out`
  // (its settings go into out.settings); reports bad values through `r`.
  void (*parse)(YamlReader& r, const Fields& fields, DriverConfig& out);
  // The channels and links of a parsed driver (never fails: parse checked it).
  DriverClaims (*claims)(const DriverConfig& d);
  // Markdown for docs/config.md after the kind's tables (may return "").
  std::string (*doc)();
};

// Adds a kind (io/drivers/registry.cpp does, for every built-in driver, before
// main() runs). Kinds keep the order they were added in.
void register_driver_kind(const DriverKind* kind);
std::span<const DriverKind* const> driver_kinds();
const DriverKind* find_driver_kind(std::string_view kind);
// "sim" or "sim, modbus": for "expected one of ..." messages.
std::string known_driver_kinds();

}  // namespace rtplc::config
