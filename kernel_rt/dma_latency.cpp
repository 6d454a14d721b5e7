// /dev/cpu_dma_latency request held open for the runtime's lifetime (spec: runtime.md,
// "Tasks and the scheduler").
#include "kernel_rt/dma_latency.h"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>
#include <cerrno>
#include <cstring>
#include <utility>

namespace rtplc::kernel_rt {

CpuDmaLatencyRequest::CpuDmaLatencyRequest(int32_t max_latency_us, const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    status_ = err == ENOENT
                  ? fmt::format(
                        "{} absent: CPU idle states are not limited (kernel without PM QoS)", path)
                  : fmt::format("{} not opened ({}): CPU idle states are not limited; run as root",
                                path, std::strerror(err));
    return;
  }
  // The kernel takes the value as a raw 32-bit integer (it also accepts hex text, but the
  // binary form is the documented one).
  const ssize_t n = ::write(fd, &max_latency_us, sizeof max_latency_us);
  if (n != static_cast<ssize_t>(sizeof max_latency_us)) {
    const int err = n < 0 ? errno : EIO;
    ::close(fd);
    status_ = fmt::format("{} not written ({}): CPU idle states are not limited", path,
                          std::strerror(err));
    return;
  }
  fd_ = fd;
  status_ =
      fmt::format("{} held at {} us: CPUs stay out of deeper idle states", path, max_latency_us);
}

CpuDmaLatencyRequest::~CpuDmaLatencyRequest() {
  release();
}

CpuDmaLatencyRequest::CpuDmaLatencyRequest(CpuDmaLatencyRequest&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), status_(std::move(other.status_)) {}

CpuDmaLatencyRequest& CpuDmaLatencyRequest::operator=(CpuDmaLatencyRequest&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = std::exchange(other.fd_, -1);
    status_ = std::move(other.status_);
  }
  return *this;
}

void CpuDmaLatencyRequest::release() noexcept {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

}  // namespace rtplc::kernel_rt
