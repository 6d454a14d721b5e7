// Folder helpers (see files.h).
#include "common/files.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

namespace rtplc {

std::string folder_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

Result<void> make_folders(const std::string& dir, mode_t mode, mode_t parent_mode) {
  if (dir.empty() || dir == "/" || dir == ".") return {};
  struct stat st {};
  if (stat(dir.c_str(), &st) == 0) return {};
  if (auto r = make_folders(folder_of(dir), parent_mode, parent_mode); !r) return r;
  if (mkdir(dir.c_str(), mode) != 0 && errno != EEXIST) {
    return make_error("cannot create " + dir + ": " + std::strerror(errno));
  }
  return {};
}

}  // namespace rtplc
