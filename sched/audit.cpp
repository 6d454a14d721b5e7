// The audit trail (see audit.h).
#include "sched/audit.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "common/files.h"

namespace rtplc::sched {

Result<void> AuditLog::append(const std::string& line) {
  if (path_.empty()) return {};
  std::string text = line;
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  text += '\n';
  struct stat st {};
  if (lstat(path_.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
      static_cast<size_t>(st.st_size) + text.size() > kMaxBytes) {
    const std::string old = path_ + ".1";
    if (std::rename(path_.c_str(), old.c_str()) != 0) {
      return make_error("audit trail " + path_ + ": cannot rotate: " + std::strerror(errno));
    }
  }
  const int fd = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) return make_error("audit trail " + path_ + ": " + std::strerror(errno));
  const int err = write_fully(fd, text.data(), text.size());
  ::close(fd);
  if (err != 0) return make_error("audit trail " + path_ + ": " + std::strerror(err));
  return {};
}

Result<std::vector<std::string>> AuditLog::tail(size_t n) const {
  std::vector<std::string> lines;
  for (const std::string& p : {path_ + ".1", path_}) {
    auto text = read_file_bounded(p, 2 * kMaxBytes, FollowLinks::kNo);
    if (!text) {
      if (is_missing_file_error(text.error())) continue;
      return make_error(text.error());
    }
    size_t from = 0;
    while (from < text->size()) {
      size_t nl = text->find('\n', from);
      if (nl == std::string::npos) nl = text->size();
      if (nl > from) lines.push_back(text->substr(from, nl - from));
      from = nl + 1;
    }
  }
  if (lines.size() > n) lines.erase(lines.begin(), lines.end() - static_cast<std::ptrdiff_t>(n));
  return lines;
}

}  // namespace rtplc::sched
