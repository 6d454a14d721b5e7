// The `modbus-server` I/O driver (issue 9, item 2): a Modbus TCP server inside
// the runtime for SCADA and HMIs (config.h says what it serves, requests.h how
// it answers, server.h how it talks TCP).
//
// Where the values come from: the server's thread reads each exposed channel
// from the process image when a request asks for it, through the image's own
// reader protocol (io/process_image.h: the last completed snapshot of the
// channel's region, acquire loads, version re-check; the image's writers never
// wait for it) and with the output's delivery quality folded in, exactly as
// `rtplc monitor` reads. No second copy is kept: a copy taken by the bridge
// cycle would only add a driver period of age and a second protocol.
//
// Where writes go: only to set-points, through DriverSetup::set_point, the path
// of `rtplc set` (the runtime's checks, retained on disk first, logged). Task
// outputs and inputs are never written: they are not writable items (requests.h).
//
// The bridge thread (the driver's period) only copies the server's counters
// into the driver's link row; the driver provides no input and consumes no
// output (config.cpp claims).
#pragma once

#include <memory>
#include <vector>

#include "io/drivers/driver.h"
#include "io/drivers/modbus_server/config.h"
#include "io/drivers/modbus_server/requests.h"
#include "io/drivers/modbus_server/server.h"

namespace rtplc::modbus_server {

class ServerDriver final : public io::Driver {
 public:
  explicit ServerDriver(const io::DriverSetup& setup);
  ~ServerDriver() override;
  // Finds every exposed label among the image's channels; an error names the entry.
  Result<void> prepare();
  uint16_t port() const { return server_ ? server_->port() : 0; }

 private:
  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_joined() noexcept override;
  // The server's counters -> the link row (the bridge thread; after it ended, the control thread).
  void publish_counters() noexcept;

  const ServerSettings& settings_;
  std::vector<uint32_t> channel_;  // per exposed item: its index in the image's channel table
  std::unique_ptr<RequestHandler> handler_;
  std::unique_ptr<TcpServer> server_;
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::modbus_server
