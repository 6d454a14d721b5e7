// The editor's workspace (`rtplc web --workspace DIR`): the folder whose .fbd
// files and their layout sidecars the page lists, opens and saves. Names are
// plain file names (no folders, no dot files); nothing is read or written
// through a symbolic link, so a link planted in the folder cannot make the
// console (often run by the runtime's owner, root on a plant box) read or
// overwrite anything else. Saves are atomic: a crash leaves the old file or
// the new one, whole.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.h"

namespace rtplc::editor {

class Workspace {
 public:
  static constexpr size_t kMaxFile = 4u << 20;

  // Makes sure `dir` is a folder (created 0750 when missing).
  static Result<Workspace> open(const std::string& dir);

  struct Entry {
    std::string name;
    uint64_t bytes = 0;
    int64_t mtime_s = 0;
    bool has_layout = false;
  };
  struct File {
    std::string text;
    std::optional<nlohmann::json> layout;  // the sidecar, when there is one
  };

  const std::string& dir() const { return dir_; }
  // The .fbd files (and .sfc and .xml, which open read-only), by name.
  Result<std::vector<Entry>> list() const;
  Result<File> load(const std::string& name) const;
  // Writes NAME and NAME.layout (when `layout` is given).
  Result<void> save(const std::string& name, const std::string& text, const nlohmann::json* layout) const;

  // Why `name` is not a workspace file name, or "" when it is one.
  static std::string name_problem(const std::string& name);

 private:
  explicit Workspace(std::string dir) : dir_(std::move(dir)) {}
  std::string dir_;
};

}  // namespace rtplc::editor
