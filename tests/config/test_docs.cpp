// The schema as the one source of truth (style.md practice 9): docs/config.md is
// exactly what config_reference_markdown() generates from it, and the tables
// themselves are well-formed. RTPLC_UPDATE_DOCS=1 rewrites the doc instead of
// failing, after a deliberate schema change.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "config/config.h"
#include "config/driver_kinds.h"
#include "config/schema.h"

namespace rtplc::config {
namespace {

const std::string kDocPath = std::string(RTPLC_SOURCE_DIR) + "/docs/config.md";

std::vector<const SectionSpec*> all_sections() {
  std::vector<const SectionSpec*> v = {&top_section(), &runtime_section(), &task_section(),
                                       &driver_section()};
  for (const DriverKind* k : driver_kinds()) {
    v.push_back(k->keys);
    for (const SectionSpec* s : k->subsections) v.push_back(s);
  }
  return v;
}

TEST(Docs, committed_reference_matches_the_schema) {
  const std::string generated = config_reference_markdown();
  const char* update = std::getenv("RTPLC_UPDATE_DOCS");
  if (update && std::string(update) == "1") {
    std::ofstream(kDocPath, std::ios::binary) << generated;
  }
  std::ifstream f(kDocPath, std::ios::binary);
  ASSERT_TRUE(f) << "docs/config.md is missing; run with RTPLC_UPDATE_DOCS=1 to write it";
  std::stringstream ss;
  ss << f.rdbuf();
  EXPECT_EQ(ss.str(), generated)
      << "docs/config.md is out of date; rerun this test with RTPLC_UPDATE_DOCS=1";
}

TEST(Docs, reference_covers_every_key_and_kind) {
  const std::string doc = config_reference_markdown();
  for (const SectionSpec* s : all_sections()) {
    for (const KeySpec& k : s->keys) {
      EXPECT_NE(doc.find("| `" + std::string(k.key) + "` |"), std::string::npos) << k.key;
    }
  }
  for (const DriverKind* k : driver_kinds()) {
    EXPECT_NE(doc.find("`kind: " + std::string(k->kind) + "`"), std::string::npos);
  }
  // The sample diagnostics are real output of the loader.
  EXPECT_NE(doc.find("plant.yaml:3:5: error: unknown key 'perod' in a task; did you mean "
                     "'period'?"),
            std::string::npos);
}

TEST(Schema, sections_have_unique_documented_keys) {
  for (const SectionSpec* s : all_sections()) {
    std::set<std::string> seen;
    EXPECT_FALSE(s->keys.empty()) << s->id;
    for (const KeySpec& k : s->keys) {
      EXPECT_TRUE(seen.insert(k.key).second) << s->id << "." << k.key;
      EXPECT_NE(std::string(k.meaning), "") << k.key;
      EXPECT_TRUE(k.required || *k.default_text) << s->id << "." << k.key << " needs a default";
      if (k.type == ValueType::kChoice) {
        EXPECT_NE(k.choices, nullptr) << k.key;
      }
      if (k.type == ValueType::kList) {
        ASSERT_NE(k.choices, nullptr) << k.key;
        EXPECT_LE(k.min, k.max) << k.key;
      }
      if (k.type == ValueType::kInteger || k.type == ValueType::kDuration) {
        EXPECT_LT(k.min, k.max) << k.key;
      }
    }
  }
}

TEST(Schema, driver_kinds_are_unique_and_found_by_name) {
  std::set<std::string> kinds;
  for (const DriverKind* k : driver_kinds()) {
    EXPECT_TRUE(kinds.insert(k->kind).second) << k->kind;
    EXPECT_EQ(find_driver_kind(k->kind), k);
    ASSERT_NE(k->parse, nullptr);
    // A kind's keys must not shadow the keys every driver has.
    for (const KeySpec& key : k->keys->keys) {
      EXPECT_EQ(find_key(driver_section(), key.key), nullptr) << k->kind << "." << key.key;
    }
  }
  EXPECT_EQ(find_driver_kind("nope"), nullptr);
  EXPECT_EQ(known_driver_kinds().rfind("sim", 0), 0u);  // the built-in kind comes first
}

TEST(Schema, documented_defaults_are_the_applied_ones) {
  const KeySpec* band = find_key(runtime_section(), "priority_band");
  ASSERT_NE(band, nullptr);
  EXPECT_EQ(std::string(band->default_text),
            "[" + std::to_string(kDefaultBandLo) + ", " + std::to_string(kDefaultBandHi) + "]");
  EXPECT_EQ(std::string(find_key(runtime_section(), "name")->default_text), kDefaultRuntimeName);
  EXPECT_EQ(std::string(find_key(driver_section(), "period")->default_text),
            format_duration(kDefaultDriverPeriod));
  EXPECT_EQ(describe_allowed(*find_key(task_section(), "period")), "10us..3600s");
  EXPECT_EQ(describe_allowed(*find_key(task_section(), "priority")), "1..98");
  EXPECT_EQ(describe_allowed(*find_key(task_section(), "overrun")), "`skip`, `stop`");
  EXPECT_EQ(describe_allowed(*find_key(top_section(), "tasks")), "1..16 entries");
}

}  // namespace
}  // namespace rtplc::config
