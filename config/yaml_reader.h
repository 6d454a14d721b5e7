// Reading schema-checked values out of yaml-cpp nodes (spec runtime.md,
// "Configuration": "Unknown keys and bad values are errors with the file
// position"). Internal to config/: the loader and each driver kind's parser use
// it so every key is checked the same way and every message has the same shape.
// Each reader reports into one DiagnosticList and returns nullopt on a bad
// value, so one load collects every problem instead of stopping at the first.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/diagnostic.h"
#include "config/schema.h"
#include "config/values.h"

namespace rtplc::config {

// One key of a map as the file gives it. Never assign to the nodes of a Field
// that already holds some: yaml-cpp's Node::operator= rebinds the node inside
// the document, so it would rewrite the file's tree. Build a new Field instead.
struct Field {
  const KeySpec* spec = nullptr;
  YAML::Node key;
  YAML::Node value;
  SourcePos key_pos;
  SourcePos pos;       // the value, or the key when the value is empty (yaml-cpp
                       // marks an empty value at the next token, which misleads)
  uint32_t width = 1;  // caret width at `pos`
};

// The known keys of one map, first occurrence of each.
class Fields {
 public:
  Fields() = default;
  Fields(std::vector<std::span<const KeySpec>> specs, std::vector<Field> found, SourcePos where)
      : specs_(std::move(specs)), found_(std::move(found)), where_(where) {}

  // The field for `key`, or nullptr when the file does not give it. `key` must
  // be a key of the schema passed to YamlReader::fields(): asking for another is
  // a bug in the loader, caught by the first test that reaches it.
  const Field* get(std::string_view key) const;
  // Where the map is (its first key, or the line that holds it).
  SourcePos where() const { return where_; }
  bool is_map() const { return !specs_.empty(); }

 private:
  std::vector<std::span<const KeySpec>> specs_;
  std::vector<Field> found_;
  SourcePos where_;
};

class YamlReader {
 public:
  YamlReader(DiagnosticList& diags, std::string base_dir)
      : diags_(diags), base_dir_(std::move(base_dir)) {}

  DiagnosticList& diags() { return diags_; }
  const std::string& base_dir() const { return base_dir_; }

  // 1-based position of a node; {0, 0} when yaml-cpp has none.
  static SourcePos pos(const YAML::Node& n);
  // Caret width of a node: its scalar text (with quotes), else 1.
  static uint32_t width(const YAML::Node& n);

  void error(SourcePos p, std::string msg, uint32_t w = 1) { diags_.error(p, std::move(msg), w); }
  void error(const Field& f, std::string msg) { diags_.error(f.pos, std::move(msg), f.width); }
  void note(SourcePos p, std::string msg, uint32_t w = 1) { diags_.note(p, std::move(msg), w); }
  void warning(SourcePos p, std::string msg, uint32_t w = 1) {
    diags_.warning(p, std::move(msg), w);
  }

  // Checks that `map` is a map (an empty value counts as an empty map) whose
  // keys are all in `keys`: unknown keys get a "did you mean", duplicates and
  // non-scalar keys are errors, missing required keys are reported at `where`.
  // With `report_unknown` false, keys outside `keys` pass silently (used while
  // a driver's kind is unknown, so only the kind is blamed). `noun` names the
  // map in messages ("a task").
  Fields fields(const YAML::Node& map, SourcePos where, std::string_view noun,
                std::vector<std::span<const KeySpec>> keys, bool report_unknown = true);

  // The items of a kList field, with its length checked against the row's
  // min/max. An empty value is an empty list. nullopt when not a list.
  std::optional<std::vector<YAML::Node>> list(const Field& f);

  // Typed values of a field, checked against its row.
  std::optional<std::string> name(const Field& f);
  std::optional<std::string> path(const Field& f);  // resolved against base_dir
  std::optional<double> duration(const Field& f);
  std::optional<int64_t> integer(const Field& f);
  std::optional<std::pair<int64_t, int64_t>> integer_pair(const Field& f);
  std::optional<bool> boolean(const Field& f);
  std::optional<std::string> choice(const Field& f);
  std::optional<ChannelAddress> channel(const Field& f);
  // A non-empty string (for kinds whose value syntax is checked elsewhere).
  std::optional<std::string> text(const Field& f);

  // A finite number anywhere (e.g. a safe output's value); `what` names it.
  std::optional<double> real(const YAML::Node& n, SourcePos fallback, std::string_view what);

  // "a list", "a map", "nothing", "'abc'": what the file gave, for messages.
  static std::string describe_node(const YAML::Node& n);

 private:
  // Reports "'key' expects TYPE, got WHAT" and returns false unless `f` is a
  // plain scalar; `quoted_ok` lets strings like "10ms" be quoted.
  bool expect_scalar(const Field& f, bool quoted_ok);

  DiagnosticList& diags_;
  std::string base_dir_;
};

}  // namespace rtplc::config
