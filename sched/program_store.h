// Online change that survives a restart (what CODESYS calls the boot
// application): the runtime keeps the source of the program each task runs in
// its state folder, content-addressed (`<hash>.prog`), and a manifest of each
// task's versions, newest last. A swap is acknowledged only after both are on
// disk (written atomically and fsynced, common/files.h), so after a crash or
// `kill -9` a restart runs the code the operator last swapped in — and says so —
// unless the configuration asks for its own files (`runtime.programs: config`).
// Rollback walks the history back, one version at a time.
//
// Written by the control thread only; never on the RT path.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/result.h"

namespace rtplc::sched {

struct ProgramVersion {
  std::string hash;     // 16 hex digits of FNV-1a 64 over the source text
  int64_t realtime_ns = 0;
  std::string origin;   // "config examples/seed_pid.fbd", "swap new.fbd", "rollback"
};

class ProgramStore {
 public:
  static constexpr size_t kHistory = 8;  // versions kept per task

  ProgramStore() = default;
  // `dir` holds the sources; the manifest is `dir`/programs.manifest.
  explicit ProgramStore(std::string dir) : dir_(std::move(dir)) {}

  const std::string& dir() const { return dir_; }
  // Reads the manifest; a missing one is an empty store. A damaged line is an
  // error naming it (the caller then starts from the configuration's files).
  Result<void> load();

  static std::string hash_of(const std::string& source);
  // The version a task runs now, if the store knows one.
  std::optional<ProgramVersion> current(const std::string& task) const;
  const std::vector<ProgramVersion>& history(const std::string& task) const;
  // The source of a stored version.
  Result<std::string> source(const std::string& hash) const;

  // Stores `source` (if not there yet) and makes it the task's current version;
  // both reach the disk before this returns.
  Result<ProgramVersion> push(const std::string& task, const std::string& source, std::string origin);
  // Drops the task's current version (after a swap that did not take, or a
  // rollback); the one before it becomes current.
  Result<void> pop(const std::string& task);

 private:
  Result<void> save() const;

  std::string dir_;
  std::map<std::string, std::vector<ProgramVersion>> versions_;
};

}  // namespace rtplc::sched
