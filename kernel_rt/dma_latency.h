// Holds a CPU wake-up latency request on /dev/cpu_dma_latency for as long as the object lives
// (spec: runtime.md, "Tasks and the scheduler": hold /dev/cpu_dma_latency at 0).
//
// Writing a 32-bit value to that file asks the kernel's PM QoS layer to keep every CPU out of
// idle states whose exit latency exceeds it; 0 means "stay in the shallowest state", so a
// timer wake-up of an RT task does not first wait tens of microseconds for a deep C-state to
// exit. The request lasts exactly as long as the file stays open, hence RAII. When the file is
// missing or not writable the object is simply inactive: the runtime works, with more jitter.
#pragma once

#include <cstdint>
#include <string>

namespace rtplc::kernel_rt {

inline constexpr const char* kCpuDmaLatencyPath = "/dev/cpu_dma_latency";

class CpuDmaLatencyRequest {
 public:
  // Holds nothing; assign a request to it later.
  CpuDmaLatencyRequest() = default;
  // Opens `path` and writes `max_latency_us`. Never throws; see active() and status().
  explicit CpuDmaLatencyRequest(int32_t max_latency_us,
                                const std::string& path = kCpuDmaLatencyPath);
  ~CpuDmaLatencyRequest();
  CpuDmaLatencyRequest(CpuDmaLatencyRequest&& other) noexcept;
  CpuDmaLatencyRequest& operator=(CpuDmaLatencyRequest&& other) noexcept;
  CpuDmaLatencyRequest(const CpuDmaLatencyRequest&) = delete;
  CpuDmaLatencyRequest& operator=(const CpuDmaLatencyRequest&) = delete;

  // True while the request is in force.
  bool active() const noexcept { return fd_ >= 0; }
  // One line for the log: what is held, or why nothing is.
  const std::string& status() const noexcept { return status_; }
  // Drops the request now (the destructor does the same).
  void release() noexcept;

 private:
  int fd_ = -1;
  std::string status_ = "no CPU latency requested";
};

}  // namespace rtplc::kernel_rt
