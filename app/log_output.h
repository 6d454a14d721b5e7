// Where `rtplc run` logs: its standard output, and when that goes away (the
// reader of a pipe or FIFO died, stdout was closed, the disk behind it is
// full) a file in the runtime's own private folder. A PLC must never die of
// its log: SIGPIPE is ignored by `run`, and a failed write moves the log
// instead of losing it or stopping the plant (spec: runtime.md, "Logging").
#pragma once

#include <spdlog/sinks/base_sink.h>

#include <mutex>
#include <string>

namespace rtplc::app {

class RuntimeLogSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  // `fd` is the primary output (stdout); `fallback_path` the file the log
  // moves to when a write to `fd` fails for good (EPIPE, EBADF, EIO, ENOSPC).
  RuntimeLogSink(int fd, std::string fallback_path);
  ~RuntimeLogSink() override;

  const std::string& fallback_path() const { return path_; }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override;
  void flush_() override {}

 private:
  void move_to_fallback(int error);
  void write_fallback(const char* p, size_t n);

  int fd_;
  bool color_;
  int fallback_fd_ = -1;
  bool fallback_failed_ = false;
  size_t fallback_bytes_ = 0;
  std::string path_;
};

// Installs the sink as spdlog's default logger and ignores SIGPIPE for the
// process; returns the sink so the caller can say where the log went.
std::shared_ptr<RuntimeLogSink> install_runtime_log(const std::string& fallback_path);

}  // namespace rtplc::app
