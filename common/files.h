// Folder helpers for the files the runtime owns (retain file, control socket).
#pragma once

#include <string>
#include <sys/types.h>

#include "common/result.h"

namespace rtplc {

// The folder part of a path: "/var/lib/rtplc" for "/var/lib/rtplc/x.retain",
// "/" for "/x", "." for "x".
std::string folder_of(const std::string& path);

// Creates `dir` and any missing parents (mode `parent_mode`); `dir` itself, if
// created, gets `mode`. Existing folders are left as they are.
Result<void> make_folders(const std::string& dir, mode_t mode, mode_t parent_mode);

}  // namespace rtplc
