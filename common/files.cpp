// Folder helpers (see files.h).
#include "common/files.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace rtplc {

namespace {
constexpr const char* kMissing = ": no such file";

const char* kind_of(mode_t m) {
  if (S_ISDIR(m)) return "a folder, not a file";
  if (S_ISFIFO(m)) return "a FIFO (named pipe), not a regular file";
  if (S_ISCHR(m)) return "a character device, not a regular file";
  if (S_ISBLK(m)) return "a block device, not a regular file";
  if (S_ISSOCK(m)) return "a socket, not a regular file";
  return "not a regular file";
}

// "1777", as chmod takes it.
std::string mode_text(mode_t m) {
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(m & 07777));
  return mode;
}

std::string size_text(size_t bytes) {
  if (bytes >= (size_t{1} << 20) && bytes % (size_t{1} << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  if (bytes >= 1024 && bytes % 1024 == 0) return std::to_string(bytes >> 10) + " KiB";
  return std::to_string(bytes) + " bytes";
}
}  // namespace

Result<std::string> read_file_bounded(const std::string& path, size_t max_bytes, FollowLinks follow) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer.
  int flags = O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY;
  if (follow == FollowLinks::kNo) flags |= O_NOFOLLOW;
  const int fd = ::open(path.c_str(), flags);
  if (fd < 0) {
    const int e = errno;
    if (e == ENOENT) return make_error(path + kMissing);
    if (e == ELOOP && follow == FollowLinks::kNo) {
      return make_error(path + ": is a symbolic link; refusing to follow it here");
    }
    return make_error(path + ": cannot open: " + std::strerror(e));
  }
  struct stat st {};
  if (fstat(fd, &st) != 0) {
    const int e = errno;
    close(fd);
    return make_error(path + ": cannot inspect: " + std::strerror(e));
  }
  if (!S_ISREG(st.st_mode)) {
    close(fd);
    return make_error(path + ": is " + kind_of(st.st_mode));
  }
  if (static_cast<unsigned long long>(st.st_size) > max_bytes) {
    close(fd);
    return make_error(path + ": is " + std::to_string(st.st_size) + " bytes; at most " +
                      size_text(max_bytes) + " are read");
  }
  // The size can change while we read (or be 0 for /proc files): read until
  // the end, never past the limit.
  std::string text;
  text.resize(static_cast<size_t>(st.st_size) + 1);
  size_t got = 0;
  for (;;) {
    if (got == text.size()) {
      if (text.size() > max_bytes) break;
      text.resize(std::min(max_bytes + 1, text.size() * 2 + 4096));
    }
    const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      close(fd);
      return make_error(path + ": cannot read: " + std::strerror(e));
    }
    if (n == 0) break;
    got += static_cast<size_t>(n);
  }
  close(fd);
  if (got > max_bytes) {
    return make_error(path + ": is larger than " + size_text(max_bytes) + "; at most that is read");
  }
  text.resize(got);
  return text;
}

bool is_missing_file_error(const std::string& error) {
  const size_t n = std::strlen(kMissing);
  return error.size() >= n && error.compare(error.size() - n, n, kMissing) == 0;
}

std::string file_error_reason(const std::string& path, const std::string& error) {
  return error.rfind(path + ": ", 0) == 0 ? error.substr(path.size() + 2) : error;
}

bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (stat(a.c_str(), &sa) != 0 || stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

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

int write_fully(int fd, const char* data, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += w;
    n -= static_cast<size_t>(w);
  }
  return 0;
}

namespace {
bool write_all(int fd, std::string_view s) { return write_fully(fd, s.data(), s.size()) == 0; }
}  // namespace

Result<void> write_file_atomically(const std::string& path, const std::string& text, mode_t mode) {
  return write_file_atomically(path, mode, [&](const FileSink& sink) { return sink(text); });
}

Result<void> write_file_atomically(const std::string& path, mode_t mode,
                                   const std::function<bool(const FileSink&)>& body) {
  const std::string dir = folder_of(path);
  if (auto r = make_folders(dir, 0750, 0750); !r) return r;
  const std::string tmp = path + ".tmp";
  // A .tmp left by a crash is ours to remove, but only a plain file: a link or
  // anything else there was put by someone else, and we refuse to write.
  struct stat old {};
  if (lstat(tmp.c_str(), &old) == 0) {
    if (!S_ISREG(old.st_mode)) {
      return make_error("refusing to write " + tmp + ": it exists and is not a plain file");
    }
    unlink(tmp.c_str());
  }
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, mode);
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
      if (piece.size() > kChunk) return written = write_all(fd, piece);
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

Result<void> ensure_private_folder(const std::string& dir, bool enterable) {
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
  // Ours: 0700 and 0711 are modes we set ourselves (the config's grants decide).
  if ((st.st_mode & 07777) == 0700 || (st.st_mode & 07777) == 0711) {
    const mode_t want = enterable ? 0711 : 0700;
    if ((st.st_mode & 07777) != want && chmod(dir.c_str(), want) != 0) {
      return make_error("cannot set the mode of " + dir + ": " + std::strerror(errno));
    }
    return {};
  }
  if ((st.st_mode & 077) != 0) {
    const std::string mode = mode_text(st.st_mode);
    // A folder others may write to (/tmp, /var/tmp, a shared drop folder) is
    // shared on purpose: never advise changing it, advise a folder of our own.
    if ((st.st_mode & (S_ISVTX | S_IWGRP | S_IWOTH)) != 0) {
      return make_error("refusing " + dir + ": it is a shared folder (mode " + mode +
                        "), where other users could replace or read what the runtime puts "
                        "there; name a path in a folder of the runtime's own (created 0700 "
                        "when missing), e.g. " + dir + "/rtplc-" + std::to_string(geteuid()) +
                        "/, or leave the setting out to use the default");
    }
    return make_error("refusing " + dir + ": its mode " + mode +
                      " lets other users in; the runtime's folder must be private (mode 0700): "
                      "name a folder of the runtime's own, or, if only this runtime uses " + dir +
                      ", chmod 700 " + dir);
  }
  return {};
}

bool socket_owner_trusted(const std::string& socket_path, uint32_t owner) {
  const std::string dir = folder_of(socket_path);
  struct stat st {};
  return lstat(dir.c_str(), &st) == 0 && S_ISDIR(st.st_mode) && st.st_uid == owner &&
         (st.st_mode & (S_IWGRP | S_IWOTH)) == 0;
}

Result<void> ensure_state_folder(const std::string& dir, bool create) {
  struct stat st {};
  if (lstat(dir.c_str(), &st) != 0) {
    if (errno != ENOENT) return make_error("cannot inspect " + dir + ": " + std::strerror(errno));
    if (!create) return {};  // `check`: nothing there yet, nothing to refuse
    if (auto r = make_folders(dir, 0700, 0755); !r) return r;
    if (lstat(dir.c_str(), &st) != 0) return make_error("cannot inspect " + dir + ": " + std::strerror(errno));
  }
  if (S_ISLNK(st.st_mode)) {
    return make_error("refusing " + dir + ": it is a symbolic link; the runtime's state must live in a real folder "
                      "(a link would let whoever made it choose what the runtime boots)");
  }
  if (!S_ISDIR(st.st_mode)) return make_error("refusing " + dir + ": it is not a folder");
  if (st.st_uid != geteuid()) {
    return make_error("refusing " + dir + ": it belongs to uid " + std::to_string(st.st_uid) +
                      ", not to this user (uid " + std::to_string(geteuid()) +
                      "), who could replace the programs and set-points the runtime starts with; "
                      "give runtime.retain_file a folder of this user's own");
  }
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) != 0) {
    return make_error("refusing " + dir + ": other users may write to it (mode " + mode_text(st.st_mode) +
                      "), and so replace the programs and set-points the runtime starts with; "
                      "give runtime.retain_file a folder of the runtime's own (created 0700 when missing)");
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
