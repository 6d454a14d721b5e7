// Atomic retain file (see retain.h).
#include "sched/retain.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/files.h"

namespace rtplc::sched {
namespace {

bool write_all(int fd, const std::string& s) {
  size_t done = 0;
  while (done < s.size()) {
    const ssize_t n = write(fd, s.data() + done, s.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

Result<void> RetainStore::load() {
  values_.clear();
  std::ifstream f(path_);
  if (!f) {
    if (errno == ENOENT) return {};
    return make_error("cannot read " + path_ + ": " + std::strerror(errno));
  }
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string label, value, extra;
    if (!(ls >> label >> value) || (ls >> extra)) {
      return make_error(path_ + ":" + std::to_string(n) + ": expected 'LABEL VALUE'");
    }
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (*end != '\0' || !std::isfinite(v)) {
      return make_error(path_ + ":" + std::to_string(n) + ": '" + value + "' is not a number");
    }
    values_[label] = v;
  }
  return {};
}

Result<void> RetainStore::save() const {
  const std::string dir = folder_of(path_);
  if (auto r = make_folders(dir, 0750, 0750); !r) return r;
  std::string text = "# rtplc retained values: LABEL VALUE per line, replaced atomically by the runtime\n";
  char buf[64];
  for (const auto& [label, v] : values_) {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    text += label + " " + buf + "\n";
  }
  const std::string tmp = path_ + ".tmp";
  const int fd = open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0) return make_error("cannot write " + tmp + ": " + std::strerror(errno));
  const bool ok = write_all(fd, text) && fsync(fd) == 0;
  const int e = errno;
  close(fd);
  if (!ok) {
    unlink(tmp.c_str());
    return make_error("cannot write " + tmp + ": " + std::strerror(e));
  }
  if (rename(tmp.c_str(), path_.c_str()) != 0) {
    const int re = errno;
    unlink(tmp.c_str());
    return make_error("cannot replace " + path_ + ": " + std::strerror(re));
  }
  // The rename itself must reach the disk, or a power cut could bring back the old file.
  const int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    fsync(dfd);
    close(dfd);
  }
  return {};
}

}  // namespace rtplc::sched
