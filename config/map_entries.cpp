// The shared parts of driver map entries (config/map_entries.h).
#include "config/map_entries.h"

#include <string>

#include "config/yaml_reader.h"

namespace rtplc::config {

bool parse_scaling(YamlReader& r, const Fields& f, SourcePos entry, double& scale, double& offset) {
  bool ok = true;
  for (const char* key : {"scale", "offset"}) {
    const Field* k = f.get(key);
    if (k == nullptr) continue;
    if (auto v = r.real(k->value, k->pos, std::string("'") + key + "'")) {
      (std::string(key) == "scale" ? scale : offset) = *v;
    } else {
      ok = false;
    }
  }
  if (scale == 0) {
    r.error(f.get("scale") ? f.get("scale")->pos : entry, "'scale' must not be 0");
    ok = false;
  }
  return ok;
}

bool parse_write_mode(YamlReader& r, const Fields& f, bool write, WriteMode& mode) {
  const Field* k = f.get("mode");
  if (k == nullptr) return true;
  if (!write) {
    r.error(*k, "'mode' applies to write maps only");
    return false;
  }
  auto v = r.choice(*k);
  if (!v) return false;
  mode = *v == "every_cycle" ? WriteMode::kEveryCycle : WriteMode::kOnChange;
  return true;
}

void for_each_map_entry(YamlReader& r, const Fields& f,
                        const std::function<void(const YAML::Node&, SourcePos, bool)>& parse) {
  for (const char* key : {"read", "write"}) {
    const Field* list = f.get(key);
    if (list == nullptr) continue;
    auto items = r.list(*list);
    if (!items) continue;
    const bool write = std::string(key) == "write";
    for (const YAML::Node& n : *items) parse(n, list->pos, write);
  }
}

bool parse_channel_field(YamlReader& r, const Fields& f, const char* key, bool required, ChannelAddress& addr,
                         std::string& text, SourcePos* pos) {
  const Field* k = f.get(key);
  if (k == nullptr) return !required;
  if (pos != nullptr) *pos = k->pos;
  auto a = r.channel(*k);
  if (!a) return false;
  addr = *a;
  text = to_string(*a);
  return true;
}

std::optional<uint32_t> FirstSeen::again(const std::string& key, SourcePos at) {
  auto [it, fresh] = first_.emplace(key, at);
  if (fresh) return std::nullopt;
  return it->second.line;
}

void refuse_mapped_twice(YamlReader& r, FirstSeen& seen, const std::string& key, const std::string& label,
                         SourcePos at) {
  if (auto first = seen.again(key, at)) {
    r.error(at, "channel " + label + " is mapped twice (first at line " + std::to_string(*first) + ")");
  }
}

std::string used_twice(std::string_view noun, const std::string& name, uint32_t first_line) {
  return std::string(noun) + " name '" + name + "' is used twice (first at line " + std::to_string(first_line) +
         ")";
}

}  // namespace rtplc::config
