// Schema-checked reads from yaml-cpp nodes (see yaml_reader.h).
#include "config/yaml_reader.h"

#include <cmath>
#include <filesystem>
#include <limits>

namespace rtplc::config {
namespace {

// yaml-cpp tags a quoted or block scalar "!" and a plain one "?"; an explicit
// !!str is a string too. Numbers and booleans must be plain: "40" in quotes is
// a string to YAML, and reading it as 40 would hide a mistake.
bool is_quoted(const YAML::Node& n) {
  const std::string& t = n.Tag();
  return t == "!" || t == "tag:yaml.org,2002:str";
}

std::string quote(std::string_view s) {
  // Keep messages one line and short whatever the file holds.
  std::string out = "'";
  size_t n = 0;
  for (char ch : s) {
    if (++n > 40) {
      out += "...";
      break;
    }
    out += (ch == '\n' || ch == '\r' || ch == '\t') ? ' ' : ch;
  }
  return out + "'";
}

std::string key_list(const std::vector<std::span<const KeySpec>>& keys) {
  std::string s;
  for (auto span : keys) {
    for (const KeySpec& k : span) s += (s.empty() ? "" : ", ") + std::string(k.key);
  }
  return s;
}

std::string range_text(const KeySpec& k) {
  if (k.type == ValueType::kDuration) {
    return "between " + format_duration(k.min) + " and " + format_duration(k.max);
  }
  return "from " + std::to_string(static_cast<int64_t>(k.min)) + " to " +
         std::to_string(static_cast<int64_t>(k.max));
}

}  // namespace

const Field* Fields::get(std::string_view key) const {
  bool in_schema = false;
  for (auto span : specs_) {
    for (const KeySpec& k : span) in_schema = in_schema || key == k.key;
  }
  if (!in_schema && !specs_.empty()) __builtin_trap();  // a loader bug, see the header
  for (const Field& f : found_) {
    if (key == f.spec->key) return &f;
  }
  return nullptr;
}

SourcePos YamlReader::pos(const YAML::Node& n) {
  if (!n.IsDefined()) return {};
  const YAML::Mark m = n.Mark();
  if (m.line < 0 || m.column < 0) return {};
  return SourcePos{static_cast<uint32_t>(m.line) + 1, static_cast<uint32_t>(m.column) + 1};
}

uint32_t YamlReader::width(const YAML::Node& n) {
  if (!n.IsDefined() || !n.IsScalar()) return 1;
  size_t w = n.Scalar().size() + (n.Tag() == "!" ? 2 : 0);
  if (w == 0) w = 1;
  return static_cast<uint32_t>(std::min<size_t>(w, 200));
}

std::string YamlReader::describe_node(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "nothing";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a map";
  if (n.IsScalar()) return (is_quoted(n) ? "the string " : "") + quote(n.Scalar());
  return "something else";
}

Fields YamlReader::fields(const YAML::Node& map, SourcePos where, std::string_view noun,
                          std::vector<std::span<const KeySpec>> keys, bool report_unknown) {
  if (map.IsDefined() && !map.IsNull() && !map.IsMap()) {
    error(pos(map).line ? pos(map) : where,
          std::string(noun) + " must be a map of 'key: value' lines, got " + describe_node(map),
          width(map));
    return {};
  }
  const SourcePos map_pos = pos(map).line ? pos(map) : where;
  std::vector<Field> found;
  if (map.IsMap()) {
    for (auto it = map.begin(); it != map.end(); ++it) {
      const YAML::Node k = it->first;
      const YAML::Node v = it->second;
      const SourcePos kp = pos(k).line ? pos(k) : map_pos;
      if (!k.IsScalar()) {
        error(kp,
              "a key in " + std::string(noun) + " must be a plain word, got " + describe_node(k));
        continue;
      }
      const std::string& name = k.Scalar();
      const KeySpec* spec = nullptr;
      for (auto span : keys) {
        for (const KeySpec& s : span) {
          if (name == s.key) spec = &s;
        }
      }
      if (!spec) {
        if (!report_unknown) continue;
        const KeySpec* best = nullptr;
        size_t best_d = std::numeric_limits<size_t>::max();
        for (auto span : keys) {
          for (const KeySpec& s : span) {
            const size_t d = edit_distance(name, s.key);
            if (d < best_d) {
              best_d = d;
              best = &s;
            }
          }
        }
        std::string msg = "unknown key " + quote(name) + " in " + std::string(noun);
        if (best && best_d <= 2 && best_d < name.size()) {
          msg += "; did you mean '" + std::string(best->key) + "'?";
        } else if (name.find('=') != std::string::npos) {
          // "{model: fopdt:K=1,T=5}": inside braces the commas split the value.
          msg += "; a value holding commas must be quoted inside { }";
        } else {
          msg += "; expected one of: " + key_list(keys);
        }
        error(kp, std::move(msg), width(k));
        continue;
      }
      bool duplicate = false;
      for (const Field& f : found) {
        if (f.spec == spec) {
          error(kp, "duplicate key '" + name + "' in " + std::string(noun), width(k));
          note(f.key_pos, "first given here", width(f.key));
          duplicate = true;
        }
      }
      if (duplicate) continue;
      const bool empty = !v.IsDefined() || v.IsNull();
      found.push_back(
          Field{spec, k, v, kp, empty || !pos(v).line ? kp : pos(v), empty ? width(k) : width(v)});
    }
  }
  for (auto span : keys) {
    for (const KeySpec& s : span) {
      if (!s.required) continue;
      bool given = false;
      for (const Field& f : found) given = given || f.spec == &s;
      if (!given) {
        error(map_pos, std::string(noun) + " needs '" + s.key + "' (" + describe_type(s) + ")");
      }
    }
  }
  return Fields(std::move(keys), std::move(found), map_pos);
}

bool YamlReader::expect_scalar(const Field& f, bool quoted_ok) {
  const YAML::Node& v = f.value;
  if (!v.IsDefined() || v.IsNull()) {
    error(f, "'" + std::string(f.spec->key) + "' has no value; expected " + describe_type(*f.spec));
    return false;
  }
  if (!v.IsScalar() || (!quoted_ok && is_quoted(v))) {
    std::string msg = "'" + std::string(f.spec->key) + "' expects " + describe_type(*f.spec) +
                      ", got " + describe_node(v);
    if (v.IsScalar()) msg += " (leave out the quotes)";
    error(f, std::move(msg));
    return false;
  }
  return true;
}

std::optional<std::vector<YAML::Node>> YamlReader::list(const Field& f) {
  const KeySpec& k = *f.spec;
  std::vector<YAML::Node> items;
  if (f.value.IsDefined() && !f.value.IsNull()) {
    if (!f.value.IsSequence()) {
      error(f, "'" + std::string(k.key) + "' expects " + describe_type(k) +
                   " (lines starting "
                   "with '- '), got " +
                   describe_node(f.value));
      return std::nullopt;
    }
    for (auto it = f.value.begin(); it != f.value.end(); ++it) items.push_back(*it);
  }
  if (static_cast<double>(items.size()) < k.min) {
    error(f, "'" + std::string(k.key) + "' needs at least " +
                 std::to_string(static_cast<int64_t>(k.min)) + " entr" +
                 (k.min == 1 ? "y" : "ies"));
    return std::nullopt;
  }
  if (static_cast<double>(items.size()) > k.max) {
    const auto limit = static_cast<size_t>(k.max);
    const SourcePos p = pos(items[limit]).line ? pos(items[limit]) : f.pos;
    error(p, "'" + std::string(k.key) + "' holds " + std::to_string(items.size()) +
                 " entries; at most " + std::to_string(limit) + " are allowed");
    return std::nullopt;
  }
  return items;
}

std::optional<std::string> YamlReader::text(const Field& f) {
  if (!expect_scalar(f, true)) return std::nullopt;
  const std::string& s = f.value.Scalar();
  if (s.empty()) {
    error(f, "'" + std::string(f.spec->key) + "' is empty; expected " + describe_type(*f.spec));
    return std::nullopt;
  }
  return s;
}

std::optional<std::string> YamlReader::name(const Field& f) {
  auto s = text(f);
  if (!s) return std::nullopt;
  if (!is_valid_name(*s)) {
    error(f, "'" + std::string(f.spec->key) + "' must be 1 to " + std::to_string(kMaxNameLength) +
                 " letters, digits, '_' or '-', got " + quote(*s));
    return std::nullopt;
  }
  return s;
}

std::optional<std::string> YamlReader::path(const Field& f) {
  auto s = text(f);
  if (!s) return std::nullopt;
  if (s->find('\0') != std::string::npos) {
    error(f, "'" + std::string(f.spec->key) + "' holds a NUL character");
    return std::nullopt;
  }
  std::filesystem::path p(*s);
  if (p.is_relative() && !base_dir_.empty()) p = std::filesystem::path(base_dir_) / p;
  return p.lexically_normal().string();
}

std::optional<double> YamlReader::duration(const Field& f) {
  if (!expect_scalar(f, true)) return std::nullopt;
  auto d = parse_duration_s(f.value.Scalar());
  if (!d) {
    error(f, "'" + std::string(f.spec->key) + "' expects " + describe_type(*f.spec) + ", got " +
                 describe_node(f.value));
    return std::nullopt;
  }
  // A hair of slack so "10us" is not refused for rounding in the division.
  if (*d < f.spec->min * (1 - 1e-12) || *d > f.spec->max * (1 + 1e-12)) {
    error(f, "'" + std::string(f.spec->key) + "' must be " + range_text(*f.spec) + ", got " +
                 format_duration(*d));
    return std::nullopt;
  }
  // A bare number is seconds; "period: 100" is almost always 100 ms meant.
  const std::string text = f.value.Scalar();
  if (*d >= 1 && parse_real(text)) {
    warning(f.pos, "'" + std::string(f.spec->key) + ": " + text + "' has no unit, so it means " +
                       format_duration(*d) + "; write " + text + "s to say so, or " + text +
                       "ms if milliseconds were meant", f.width);
  }
  return d;
}

std::optional<int64_t> YamlReader::integer(const Field& f) {
  if (!expect_scalar(f, false)) return std::nullopt;
  auto v = parse_integer(f.value.Scalar());
  if (!v) {
    std::string msg = "'" + std::string(f.spec->key) + "' expects " + describe_type(*f.spec) +
                      ", got " + describe_node(f.value);
    if (parse_real(f.value.Scalar())) msg += " (no fraction allowed)";
    error(f, std::move(msg));
    return std::nullopt;
  }
  if (static_cast<double>(*v) < f.spec->min || static_cast<double>(*v) > f.spec->max) {
    error(f, "'" + std::string(f.spec->key) + "' must be " + range_text(*f.spec) + ", got " +
                 std::to_string(*v));
    return std::nullopt;
  }
  return v;
}

std::optional<std::pair<int64_t, int64_t>> YamlReader::integer_pair(const Field& f) {
  const std::string key = f.spec->key;
  if (!f.value.IsSequence() || f.value.size() != 2) {
    error(f, "'" + key + "' expects " + describe_type(*f.spec) + ", got " +
                 (f.value.IsSequence() ? "a list of " + std::to_string(f.value.size())
                                       : describe_node(f.value)));
    return std::nullopt;
  }
  int64_t v[2] = {0, 0};
  bool ok = true;
  for (size_t i = 0; i < 2; ++i) {
    const YAML::Node item = f.value[i];
    // Built, never assigned: assigning to a yaml-cpp Node that refers into the
    // document rewrites the document itself.
    const Field sub{f.spec,     f.key, item, f.key_pos, pos(item).line ? pos(item) : f.pos,
                    width(item)};
    auto x = integer(sub);
    if (!x) {
      ok = false;
      continue;
    }
    v[i] = *x;
  }
  if (!ok) return std::nullopt;
  if (v[0] > v[1]) {
    error(f, "'" + key + "' must have lo <= hi, got [" + std::to_string(v[0]) + ", " +
                 std::to_string(v[1]) + "]");
    return std::nullopt;
  }
  return std::make_pair(v[0], v[1]);
}

std::optional<bool> YamlReader::boolean(const Field& f) {
  if (!expect_scalar(f, false)) return std::nullopt;
  const std::string& s = f.value.Scalar();
  if (s == "true" || s == "True" || s == "TRUE") return true;
  if (s == "false" || s == "False" || s == "FALSE") return false;
  error(f,
        "'" + std::string(f.spec->key) + "' expects true or false, got " + describe_node(f.value));
  return std::nullopt;
}

std::optional<std::string> YamlReader::choice(const Field& f) {
  if (!expect_scalar(f, true)) return std::nullopt;
  const std::string& s = f.value.Scalar();
  std::string_view choices = f.spec->choices;
  while (!choices.empty()) {
    const size_t bar = choices.find('|');
    if (choices.substr(0, bar) == s) return s;
    if (bar == std::string_view::npos) break;
    choices.remove_prefix(bar + 1);
  }
  error(f, "'" + std::string(f.spec->key) + "' expects " + describe_type(*f.spec) + ", got " +
               describe_node(f.value));
  return std::nullopt;
}

std::optional<ChannelAddress> YamlReader::channel(const Field& f) {
  if (!expect_scalar(f, true)) return std::nullopt;
  auto a = parse_channel(f.value.Scalar());
  if (!a) {
    error(f, "'" + std::string(f.spec->key) + "' expects " + describe_type(*f.spec) +
                 " (p and d 0..255, c 0..65535), got " + describe_node(f.value));
    return std::nullopt;
  }
  return a;
}

std::optional<double> YamlReader::real(const YAML::Node& n, SourcePos fallback,
                                       std::string_view what) {
  const bool empty = !n.IsDefined() || n.IsNull();
  const SourcePos p = !empty && pos(n).line ? pos(n) : fallback;
  if (empty) {
    error(p, std::string(what) + " has no value; expected a number");
    return std::nullopt;
  }
  std::optional<double> v;
  if (n.IsScalar() && !is_quoted(n)) v = parse_real(n.Scalar());
  if (!v) {
    error(p, std::string(what) + " expects a finite number, got " + describe_node(n), width(n));
    return std::nullopt;
  }
  return v;
}

}  // namespace rtplc::config
