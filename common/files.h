// File helpers: the one bounded reader every command and the runtime use, and
// the folders and files the runtime owns (retain file, control socket, store).
#pragma once

#include <cstddef>
#include <functional>
#include <string_view>
#include <string>
#include <sys/types.h>

#include "common/result.h"

namespace rtplc {

// The folder part of a path: "/var/lib/rtplc" for "/var/lib/rtplc/x.retain",
// "/" for "/x", "." for "x".
std::string folder_of(const std::string& path);

// Whether read_file_bounded follows a symbolic link at the last component.
// Files of the state folder (retain, program store) are read kNoFollow: a link
// planted there must not make a root runtime read whatever it points to.
enum class FollowLinks : unsigned char { kYes, kNo };

// Reads a whole regular file of at most `max_bytes`. Refuses, with a message
// that starts with the path and says why, anything else: a missing file, a
// folder, a FIFO, a device (/dev/zero would never end), a socket, a file over
// the limit, a link when `follow` is kNo. Never blocks on a FIFO (opened
// O_NONBLOCK, then refused) and never holds more than max_bytes + 1 in memory.
Result<std::string> read_file_bounded(const std::string& path, size_t max_bytes,
                                      FollowLinks follow = FollowLinks::kYes);
// Whether the error from read_file_bounded was "no such file".
bool is_missing_file_error(const std::string& error);
// The reason alone ("is a folder, not a file"), for messages that already
// name the path.
std::string file_error_reason(const std::string& path, const std::string& error);

// Writes all of [data, data + n) to `fd`, retrying short writes and EINTR;
// returns 0, or the errno that stopped it (EPIPE, ENOSPC, ...).
int write_fully(int fd, const char* data, size_t n);

// Whether `a` and `b` name the same existing file (same device and inode), so
// a command never writes its output over its own input.
bool same_file(const std::string& a, const std::string& b);

// Creates `dir` and any missing parents (mode `parent_mode`); `dir` itself, if
// created, gets `mode`. Existing folders are left as they are.
Result<void> make_folders(const std::string& dir, mode_t mode, mode_t parent_mode);

// Replaces `path` with `text` so that a reader — or the next start after a
// crash or power cut — finds either the old file or the new one, whole: write a
// temporary file, fsync it, rename it over `path`, fsync the folder. Creates the
// folder (0750) if needed. The temporary file is created O_EXCL|O_NOFOLLOW (a
// stale one from a crash is removed first, and only if it is a plain file), so
// a link planted at PATH.tmp is never followed.
Result<void> write_file_atomically(const std::string& path, const std::string& text, mode_t mode);
// The same, for a file written in pieces (one too big to build as one string
// first): `body` gets a sink and calls it with each piece, in order; it returns
// false to give up (nothing is replaced). Pieces are gathered into 64 KiB writes.
using FileSink = std::function<bool(std::string_view)>;
Result<void> write_file_atomically(const std::string& path, mode_t mode,
                                   const std::function<bool(const FileSink&)>& body);

// Makes sure `dir` is a folder only its owner can enter: created with mode 0700
// (parents 0755) when missing; when it exists it must be a real folder (not a
// link), owned by this process's user, with no rights for group or others.
// Refuses otherwise, saying whose it is: a folder another local user prepared
// would let that user replace our socket and read our commands.
// `enterable`: the folder is (made) 0711 instead, so others can reach a socket
// in it by name, never list or change it (a runtime that grants roles to others).
Result<void> ensure_private_folder(const std::string& dir, bool enterable = false);
// Whether a socket owned by another user `owner` may be trusted: it lies in a
// folder `owner` owns that nobody else may write (so it is that user's own,
// not one planted in a shared folder such as /tmp).
bool socket_owner_trusted(const std::string& socket_path, uint32_t owner);

// The folder of the runtime's state (retain file, block state, program store:
// what the runtime boots from). Created 0700 (parents 0755) when missing and
// `create`; refused when it is a symbolic link, belongs to another user (root
// may use root's), or other users may write to it: whoever can write there
// chooses the program and the set-points the runtime starts with. Group or
// world *read* is left to the operator (deploy may share it with a group).
Result<void> ensure_state_folder(const std::string& dir, bool create);

// An exclusive lock on a file held for the life of the object (flock): how a
// runtime knows no other runtime of the same name runs, whatever a shared-memory
// object claims. The file holds the owner's pid for messages.
class FileLock {
 public:
  FileLock() = default;
  FileLock(FileLock&& o) noexcept : fd_(o.fd_), path_(std::move(o.path_)) { o.fd_ = -1; }
  FileLock& operator=(FileLock&& o) noexcept;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock();

  // Takes the lock without waiting; fails naming the holder's pid when another
  // process holds it.
  static Result<FileLock> acquire(const std::string& path);
  bool held() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
  std::string path_;
};

}  // namespace rtplc
