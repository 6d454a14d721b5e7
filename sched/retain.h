// Retained values (spec runtime.md, "Retain"): set-points survive a restart and
// a `kill -9`. The store is written by the control thread — never by a task —
// as an atomic file replacement: write a temporary file, fsync it, rename it
// over the old one, fsync the folder. A reader therefore sees either the old or
// the new file, whole; `rtplc set` answers only after the new value is on disk.
#pragma once

#include <map>
#include <string>

#include "common/result.h"

namespace rtplc::sched {

class RetainStore {
 public:
  RetainStore() = default;
  explicit RetainStore(std::string path) : path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  // Reads the file. A missing file is an empty store; a damaged one is an error
  // (the caller decides whether to start with the initial values).
  Result<void> load();
  // Writes every value atomically (see above). Creates the folder if needed.
  Result<void> save() const;

  bool has(const std::string& label) const { return values_.count(label) != 0; }
  double get(const std::string& label) const { return values_.at(label); }
  void set(const std::string& label, double v) { values_[label] = v; }
  const std::map<std::string, double>& values() const { return values_; }

 private:
  std::string path_;
  std::map<std::string, double> values_;
};

}  // namespace rtplc::sched
