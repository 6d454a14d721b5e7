// The audit trail of operator actions (issue "values you can trust", item 4):
// every write through the control channel — set, force, unforce, swap,
// rollback, trace, stop, accepted or refused — as one line: UTC time, the
// caller's uid, the request and what the runtime answered (set and force say
// the old value: "Setpoint = 60 (was 50)"). The file lives in the state folder
// (NAME.audit, 0600, opened without following links) and is bounded: past
// kMaxBytes it becomes NAME.audit.1 (the previous .1 is dropped) and a new file
// starts, so the two hold the last 256 to 512 KiB of actions. `rtplc audit`
// prints the last lines through the control channel.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "common/result.h"

namespace rtplc::sched {

class AuditLog {
 public:
  static constexpr size_t kMaxBytes = 256 * 1024;

  AuditLog() = default;
  explicit AuditLog(std::string path) : path_(std::move(path)) {}
  const std::string& path() const { return path_; }
  // Appends one line (newlines inside become spaces). An error (a full disk)
  // is returned for the log; the action itself is not undone.
  Result<void> append(const std::string& line);
  // The last `n` lines, oldest first.
  Result<std::vector<std::string>> tail(size_t n) const;

 private:
  std::string path_;
};

}  // namespace rtplc::sched
