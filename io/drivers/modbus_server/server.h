// The modbus-server's TCP side (issue 9, item 2): one thread, below the task
// band, with one poll() loop over the listening socket and every client.
//   accept   a client whose address is not in `allow`, or one beyond
//            `max_clients`, is closed at once (counted `refused`, logged).
//   frames   cut by modbus/pdu.h; requests pipelined on one connection are
//            answered in order; a stream that is not Modbus TCP is hung up on.
//   units    a request to a unit id not answered gets exception 11.
//   idle     a client that sent nothing for `timeout` is closed (`idle_closed`).
//   replies  non-blocking; a client that stops reading while more than 64 KiB
//            of replies wait for it is closed.
// The counters are single-writer atomics (this thread stores, relaxed: each
// is read alone, as a number for the link row, by the driver's bridge thread).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "common/result.h"
#include "io/drivers/modbus_server/config.h"
#include "io/drivers/modbus_server/requests.h"
#include "io/link/socket_util.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::modbus_server {

struct ServerCounters {
  std::atomic<uint64_t> accepted{0};
  std::atomic<uint64_t> refused{0};      // not allowed, or one too many
  std::atomic<uint64_t> connected{0};    // now
  std::atomic<uint64_t> idle_closed{0};
  std::atomic<uint64_t> requests{0};
  std::atomic<uint64_t> exceptions{0};
  std::atomic<uint64_t> writes_accepted{0};  // set-points changed
  std::atomic<uint64_t> writes_refused{0};   // write requests answered with an exception
  std::atomic<uint64_t> bad_frames{0};       // connections hung up on
  std::atomic<bool> listening{false};
};

class TcpServer {
 public:
  using Log = std::function<void(bool error, const std::string& text)>;

  TcpServer(const ServerSettings& s, const RequestHandler& handler, Log log);
  ~TcpServer();
  TcpServer(const TcpServer&) = delete;
  TcpServer& operator=(const TcpServer&) = delete;

  // Binds and listens (an error says why and how to fix it: a taken port, a
  // privileged one); then start() runs the loop on its thread.
  Result<void> listen();
  Result<void> start(const std::string& thread_name, int priority, int cpu);
  void stop();
  // The port it listens on (the configured one, or the one chosen for port 0).
  uint16_t port() const { return port_; }
  const ServerCounters& counters() const { return counters_; }

  // Runs the loop on the calling thread until stop() (tests).
  void run();

 private:
  struct Client {
    link::UniqueFd fd;
    std::string peer;  // "127.0.0.1:40112"
    std::vector<uint8_t> in, out;
    int64_t last_heard_ns = 0;
  };
  void accept_clients(int64_t now);
  // False when the client is to be closed.
  bool serve(Client& c, int64_t now);
  bool flush(Client& c);

  const ServerSettings& s_;
  const RequestHandler& handler_;
  Log log_;
  link::UniqueFd listen_fd_;
  uint16_t port_ = 0;
  std::vector<Client> clients_;
  ServerCounters counters_;
  std::atomic<bool> stop_{false};
  kernel_rt::RtThread thread_;
  uint64_t refusals_logged_ = 0;
  int64_t accept_paused_until_ns_ = 0;
};

}  // namespace rtplc::modbus_server
