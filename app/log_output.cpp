// The runtime's log output (see log_output.h).
#include "app/log_output.h"

#include "common/files.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include <spdlog/spdlog.h>

namespace rtplc::app {
namespace {

// A log file the runtime writes for days: keep the current file and one
// older one, each at most this size.
constexpr size_t kMaxFallbackBytes = size_t{16} << 20;

}  // namespace

RuntimeLogSink::RuntimeLogSink(int fd, std::string fallback_path)
    : fd_(fd), color_(isatty(fd) != 0), path_(std::move(fallback_path)) {}

RuntimeLogSink::~RuntimeLogSink() {
  if (fallback_fd_ >= 0) close(fallback_fd_);
}

void RuntimeLogSink::sink_it_(const spdlog::details::log_msg& msg) {
  spdlog::memory_buf_t line;
  formatter_->format(msg, line);
  if (fd_ >= 0) {
    const bool loud = color_ && msg.level >= spdlog::level::warn;
    const char* on = msg.level >= spdlog::level::err ? "\x1b[31m" : "\x1b[33m";
    int e = loud ? write_fully(fd_, on, std::strlen(on)) : 0;
    if (e == 0) e = write_fully(fd_, line.data(), line.size());
    if (e == 0 && loud) e = write_fully(fd_, "\x1b[0m", 4);
    if (e == 0) return;
    // EAGAIN cannot happen on a blocking fd; anything else means the output
    // is gone or broken for good: move the log, keep this line.
    move_to_fallback(e);
  }
  write_fallback(line.data(), line.size());
}

void RuntimeLogSink::move_to_fallback(int error) {
  fd_ = -1;
  char when[32] = {};
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", &tm);
  const std::string note = std::string("[") + when + "] [warning] the log's standard output failed (" +
                           std::strerror(error) + "); logging continues in this file\n";
  write_fallback(note.data(), note.size());
}

void RuntimeLogSink::write_fallback(const char* p, size_t n) {
  if (fallback_failed_) return;
  if (fallback_fd_ >= 0 && fallback_bytes_ + n > kMaxFallbackBytes) {
    close(fallback_fd_);
    fallback_fd_ = -1;
    const std::string old = path_ + ".1";
    rename(path_.c_str(), old.c_str());
  }
  if (fallback_fd_ < 0) {
    // O_NOFOLLOW: the folder is the runtime's private one, but a link there
    // must still never redirect a root runtime's writes.
    fallback_fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600);
    if (fallback_fd_ < 0) {
      fallback_failed_ = true;  // nowhere left to log; the runtime keeps running
      return;
    }
    struct stat st{};
    fallback_bytes_ = fstat(fallback_fd_, &st) == 0 ? static_cast<size_t>(st.st_size) : 0;
  }
  if (write_fully(fallback_fd_, p, n) == 0) fallback_bytes_ += n;
}

std::shared_ptr<RuntimeLogSink> install_runtime_log(const std::string& fallback_path) {
  // Without this, the first log line after a pipe's reader dies kills the
  // runtime (exit 141) before it drives its safe outputs.
  signal(SIGPIPE, SIG_IGN);
  auto sink = std::make_shared<RuntimeLogSink>(STDOUT_FILENO, fallback_path);
  auto logger = std::make_shared<spdlog::logger>("rtplc", sink);
  spdlog::set_default_logger(logger);
  return sink;
}

}  // namespace rtplc::app
