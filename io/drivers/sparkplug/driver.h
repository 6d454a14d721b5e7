// The `sparkplug` I/O driver (docs/sparkplug.md): this box as a Sparkplug B
// 3.0 edge node, its tasks as devices.
//
// Threads. The bridge thread (the driver's period, like every driver's) only
// copies the link thread's counters into the link row: relaxed atomic loads
// and stores, no allocation, no lock, no syscall. The link thread (helper
// priority, below every task) does all the rest: it samples the channels
// through the image's reader protocol (io/process_image.h: the last complete
// snapshot of each region, acquire loads and a version re-check; the tasks
// never wait for a reader), encodes, talks to the broker, and hands DCMD
// writes to the operator API (DriverSetup::set_point: role operator, limits,
// retain, audit). Nothing of it runs on a task's thread or the bridge's.
//
// The devices follow the image: task t's device holds the channels whose
// ChannelDesc::users has bit t (the program's inputs, outputs and
// set-points), so a swap that changes a program's channels gives its device a
// DDEATH and a new DBIRTH, and a task that stops gets its DDEATH.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "io/drivers/driver.h"
#include "io/drivers/sparkplug/config.h"
#include "io/drivers/sparkplug/edge_node.h"
#include "io/drivers/sparkplug/mqtt_session.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::sparkplug {

class SparkplugDriver final : public io::Driver {
 public:
  explicit SparkplugDriver(const io::DriverSetup& setup);
  ~SparkplugDriver() override;
  // Checks every label the settings name against the image.
  Result<void> prepare();
  const NodeCounters& counters() const { return node_->counters(); }

 private:
  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_joined() noexcept override;
  void publish_counters() noexcept;

  void link_run();
  // The devices from the image (tasks, their channels, whether they run).
  std::vector<DeviceDef> read_devices() const;
  uint64_t layout_signature() const;
  Sample sample(uint32_t channel) const;
  // The next bdSeq (0..255), kept in the state folder before it is used.
  uint64_t next_bdseq();

  const SparkplugSettings& settings_;
  std::unique_ptr<EdgeNode> node_;        // made in prepare(); driven by the link thread
  std::unique_ptr<MqttSession> session_;  // link thread only
  // Per device (the order of read_devices()): the image regions its channels
  // live in (values and deliveries), their publication counts when last
  // sampled, and when it was last sampled: a device is sampled only when one
  // of its regions published since, or every kFullSampleNs (ages turn values stale).
  struct DeviceRegions {
    std::vector<uint32_t> regions;
    std::vector<uint64_t> seen;
    int64_t sampled_ns = 0;
  };
  std::vector<DeviceRegions> device_regions_;
  std::vector<bool> dirty_;
  void mark_dirty(int64_t now_ns);
  std::string bdseq_path_;
  uint64_t bdseq_ = 255;         // so that a first session without a file uses 0
  int64_t clock_offset_ns_ = 0;  // realtime - monotonic, refreshed each tick
  std::atomic<bool> link_stop_{false};
  std::atomic<uint8_t> link_state_{0};
  kernel_rt::RtThread link_;
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::sparkplug
