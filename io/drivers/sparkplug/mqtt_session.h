// One MQTT session with the broker over Debian's libmosquitto, driven from the
// caller's thread (loop()), never from a thread of the library's own: the link
// thread is a kernel_rt thread like every other.
//
// One session is one mosquitto client: connect() builds it with this
// session's will and clean session, and a lost session is thrown away whole.
// A new session therefore never carries messages queued in an old one (the
// library's offline queue would resend DATA with a stale seq after a
// reconnect, before the births).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.h"
#include "io/drivers/sparkplug/config.h"

struct mosquitto;
struct mosquitto_message;

namespace rtplc::sparkplug {

class MqttSession {
 public:
  struct Message {
    std::string topic;
    std::string payload;
    bool retained = false;
  };
  enum class Event : uint8_t { kNone, kUp, kRefused, kDown };

  MqttSession(const SparkplugSettings& s, std::string client_id);
  ~MqttSession();
  MqttSession(const MqttSession&) = delete;
  MqttSession& operator=(const MqttSession&) = delete;

  // Dials the broker (the TCP connect runs here; CONNACK arrives in loop());
  // the will is published by the broker if the session dies without a DISCONNECT
  // (an empty will_topic: none).
  Result<void> connect(const std::string& will_topic, const std::string& will_payload, int will_qos);
  // Moves bytes for up to timeout_ms. Returns what happened to the session.
  Event loop(int timeout_ms);
  bool up() const { return up_; }
  // Messages received since the last call.
  std::vector<Message> take_messages();
  bool publish(const std::string& topic, std::string_view payload, int qos, bool retain);
  bool subscribe(const std::string& topic, int qos);
  // Sends DISCONNECT (the broker discards the will) and flushes what is queued.
  void disconnect();
  // Why the last connect or loop failed.
  const std::string& error() const { return error_; }
  // Bytes the library still has to write (QoS 1 in flight or unsent).
  bool busy() const;

 private:
  static void on_connect(mosquitto*, void* self, int rc);
  static void on_disconnect(mosquitto*, void* self, int rc);
  static void on_message(mosquitto*, void* self, const mosquitto_message* m);

  const SparkplugSettings& s_;
  std::string client_id_;
  mosquitto* m_ = nullptr;
  bool up_ = false;
  Event pending_ = Event::kNone;
  std::string error_;
  std::vector<Message> inbox_;
};

}  // namespace rtplc::sparkplug
