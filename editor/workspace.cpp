// The editor's workspace: list, load and save .fbd files and their sidecars
// (and list and load .sfc charts and PLCopen .xml projects, read-only).
#include "editor/workspace.h"

#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>

#include "common/files.h"

namespace rtplc::editor {

std::string Workspace::name_problem(const std::string& name) {
  auto ends = [&](const char* ext) { return name.size() >= 5 && name.compare(name.size() - 4, 4, ext) == 0; };
  if (name.size() > 68 || !(ends(".fbd") || ends(".sfc") || ends(".xml")))
    return "a program's file name ends in .fbd (or .sfc, .xml: opened read-only) and is at most 68 characters";
  if (!std::isalnum(static_cast<unsigned char>(name[0]))) return "a file name starts with a letter or a digit";
  for (char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.')
      return "a file name has letters, digits, '_', '-' and '.' only (no folders)";
  }
  if (name.find("..") != std::string::npos) return "a file name has no '..'";
  return "";
}

Result<Workspace> Workspace::open(const std::string& dir) {
  if (dir.empty()) return make_error("no workspace folder given");
  if (auto r = make_folders(dir, 0750, 0755); !r) return make_error(r.error());
  struct stat st{};
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) return make_error(dir + ": not a folder");
  return Workspace(dir);
}

Result<std::vector<Workspace::Entry>> Workspace::list() const {
  DIR* d = ::opendir(dir_.c_str());
  if (d == nullptr) return make_error(dir_ + ": cannot be listed");
  std::vector<Entry> out;
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (!name_problem(name).empty()) continue;
    struct stat st{};
    if (::lstat((dir_ + "/" + name).c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;  // links left out
    struct stat lt{};
    const bool layout = ::lstat((dir_ + "/" + name + ".layout").c_str(), &lt) == 0 && S_ISREG(lt.st_mode);
    out.push_back({name, static_cast<uint64_t>(st.st_size), static_cast<int64_t>(st.st_mtime), layout});
  }
  ::closedir(d);
  std::sort(out.begin(), out.end(), [](const Entry& a, const Entry& b) { return a.name < b.name; });
  return out;
}

Result<Workspace::File> Workspace::load(const std::string& name) const {
  if (const std::string why = name_problem(name); !why.empty()) return make_error(name + ": " + why);
  auto text = read_file_bounded(dir_ + "/" + name, kMaxFile, FollowLinks::kNo);
  if (!text) return make_error(text.error());
  File f;
  f.text = std::move(text).value();
  auto layout = read_file_bounded(dir_ + "/" + name + ".layout", kMaxFile, FollowLinks::kNo);
  if (layout) {
    nlohmann::json j = nlohmann::json::parse(*layout, nullptr, false);
    if (j.is_discarded()) return make_error(name + ".layout: not JSON");
    f.layout = std::move(j);
  } else if (!is_missing_file_error(layout.error())) {
    return make_error(layout.error());
  }
  return f;
}

Result<void> Workspace::save(const std::string& name, const std::string& text, const nlohmann::json* layout) const {
  if (const std::string why = name_problem(name); !why.empty()) return make_error(name + ": " + why);
  if (name.compare(name.size() - 4, 4, ".fbd") != 0)
    return make_error(name + ": the editor saves .fbd programs; SFC charts and PLCopen projects open read-only");
  if (text.size() > kMaxFile) return make_error(name + ": larger than 4 MiB");
  for (const std::string& p : {dir_ + "/" + name, dir_ + "/" + name + ".layout"}) {
    struct stat st{};
    if (::lstat(p.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
      return make_error(p + ": is not a plain file (a link or a folder); nothing was written");
  }
  if (auto r = write_file_atomically(dir_ + "/" + name, text, 0640); !r) return r;
  if (layout) return write_file_atomically(dir_ + "/" + name + ".layout", layout->dump(1) + "\n", 0640);
  return {};
}

}  // namespace rtplc::editor
