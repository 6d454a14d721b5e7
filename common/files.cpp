// Folder helpers (see files.h).
#include "common/files.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
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

namespace {
bool write_all(int fd, const std::string& s) {
  size_t done = 0;
  while (done < s.size()) {
    const ssize_t n = ::write(fd, s.data() + done, s.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  return true;
}
}  // namespace

Result<void> write_file_atomically(const std::string& path, const std::string& text, mode_t mode) {
  return write_file_atomically(path, mode, [&](const FileSink& sink) { return sink(text); });
}

Result<void> write_file_atomically(const std::string& path, mode_t mode,
                                   const std::function<bool(const FileSink&)>& body) {
  const std::string dir = folder_of(path);
  if (auto r = make_folders(dir, 0750, 0750); !r) return r;
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, mode);
  if (fd < 0) return make_error("cannot write " + tmp + ": " + std::strerror(errno));
  constexpr size_t kChunk = 64 * 1024;
  std::string pending;
  pending.reserve(kChunk);
  bool written = true;
  const FileSink sink = [&](std::string_view piece) {
    if (!written) return false;
    if (pending.size() + piece.size() > kChunk) {
      written = write_all(fd, pending);
      pending.clear();
      if (!written) return false;
      if (piece.size() > kChunk) return written = write_all(fd, std::string(piece));
    }
    pending.append(piece);
    return true;
  };
  const bool produced = body(sink);
  const bool ok = produced && written && write_all(fd, pending) && fsync(fd) == 0;
  const int e = errno;
  close(fd);
  if (!ok) {
    unlink(tmp.c_str());
    return make_error("cannot write " + tmp + (produced ? ": " + std::string(std::strerror(e)) : std::string()));
  }
  if (rename(tmp.c_str(), path.c_str()) != 0) {
    const int re = errno;
    unlink(tmp.c_str());
    return make_error("cannot replace " + path + ": " + std::strerror(re));
  }
  // The rename itself must reach the disk, or a power cut could bring back the old file.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    fsync(dfd);
    close(dfd);
  }
  return {};
}

Result<void> ensure_private_folder(const std::string& dir) {
  if (auto r = make_folders(dir, 0700, 0755); !r) return r;
  struct stat st {};
  if (lstat(dir.c_str(), &st) != 0) return make_error("cannot inspect " + dir + ": " + std::strerror(errno));
  if (S_ISLNK(st.st_mode)) return make_error("refusing " + dir + ": it is a symbolic link, not a folder");
  if (!S_ISDIR(st.st_mode)) return make_error("refusing " + dir + ": it is not a folder");
  if (st.st_uid != geteuid()) {
    return make_error("refusing " + dir + ": it belongs to uid " + std::to_string(st.st_uid) +
                      ", not to this user (uid " + std::to_string(geteuid()) +
                      "); another user could replace what we put there. Remove it, or choose "
                      "another path");
  }
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return make_error("refusing " + dir + ": its mode " + mode +
                      " lets other users in; it must be 0700 (chmod 700 " + dir + ")");
  }
  return {};
}

FileLock& FileLock::operator=(FileLock&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) close(fd_);
    fd_ = o.fd_;
    path_ = std::move(o.path_);
    o.fd_ = -1;
  }
  return *this;
}

FileLock::~FileLock() {
  if (fd_ >= 0) close(fd_);  // releases the lock; the file stays (removing it would race)
}

Result<FileLock> FileLock::acquire(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) return make_error("cannot open the lock file " + path + ": " + std::strerror(errno));
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    char buf[32] = {};
    const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
    close(fd);
    const std::string pid = n > 0 ? std::string(buf, static_cast<size_t>(n)) : "?";
    return make_error("already running (pid " + pid.substr(0, pid.find('\n')) + ", holding " + path + ")");
  }
  const std::string pid = std::to_string(getpid()) + "\n";
  if (ftruncate(fd, 0) != 0 || pwrite(fd, pid.data(), pid.size(), 0) < 0) {
    // The pid is only for messages; the lock itself is what counts.
  }
  FileLock l;
  l.fd_ = fd;
  l.path_ = path;
  return l;
}

}  // namespace rtplc
