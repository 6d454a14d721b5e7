// One MQTT session over libmosquitto (see mqtt_session.h).
#include "io/drivers/sparkplug/mqtt_session.h"

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <mutex>

namespace rtplc::sparkplug {
namespace {

void init_library() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

}  // namespace

MqttSession::MqttSession(const SparkplugSettings& s, std::string client_id) : s_(s), client_id_(std::move(client_id)) {
  init_library();
}

MqttSession::~MqttSession() {
  if (m_) {
    mosquitto_destroy(m_);  // closes the socket without DISCONNECT: the will stands
  }
}

Result<void> MqttSession::connect(const std::string& will_topic, const std::string& will_payload, int will_qos) {
  m_ = mosquitto_new(client_id_.c_str(), true, this);  // clean session (Sparkplug 3.0)
  if (!m_) return make_error("cannot create an MQTT client (out of memory?)");
  // MQTT 5 by default: its "retain as published" subscriptions let a node see
  // that a command was published retained even when it arrives live (3.1.1
  // clears the flag then), so it can refuse it.
  mosquitto_int_option(m_, MOSQ_OPT_PROTOCOL_VERSION, s_.mqtt5 ? MQTT_PROTOCOL_V5 : MQTT_PROTOCOL_V311);
  mosquitto_connect_callback_set(m_, &MqttSession::on_connect);
  mosquitto_disconnect_callback_set(m_, &MqttSession::on_disconnect);
  mosquitto_message_callback_set(m_, &MqttSession::on_message);
  int rc = MOSQ_ERR_SUCCESS;
  if (!will_topic.empty()) {
    rc = mosquitto_will_set(m_, will_topic.c_str(), static_cast<int>(will_payload.size()), will_payload.data(),
                            will_qos, false);
    if (rc != MOSQ_ERR_SUCCESS) return make_error(fmt::format("the will: {}", mosquitto_strerror(rc)));
  }
  if (!s_.username.empty()) {
    rc = mosquitto_username_pw_set(m_, s_.username.c_str(), s_.password.empty() ? nullptr : s_.password.c_str());
    if (rc != MOSQ_ERR_SUCCESS) return make_error(fmt::format("user name: {}", mosquitto_strerror(rc)));
  }
  if (s_.tls) {
    const char* ca = s_.ca_file.empty() ? nullptr : s_.ca_file.c_str();
    rc = mosquitto_tls_set(m_, ca, ca ? nullptr : "/etc/ssl/certs", s_.cert_file.empty() ? nullptr : s_.cert_file.c_str(),
                           s_.key_file.empty() ? nullptr : s_.key_file.c_str(), nullptr);
    if (rc != MOSQ_ERR_SUCCESS) return make_error(fmt::format("TLS: {}", mosquitto_strerror(rc)));
  }
  const int keepalive = std::max(5, static_cast<int>(s_.keepalive_s + 0.5));
  rc = mosquitto_connect_async(m_, s_.host.c_str(), s_.port, keepalive);
  if (rc == MOSQ_ERR_ERRNO) return make_error(fmt::format("cannot reach {}: {}", s_.broker_text(), std::strerror(errno)));
  if (rc != MOSQ_ERR_SUCCESS) return make_error(fmt::format("cannot reach {}: {}", s_.broker_text(), mosquitto_strerror(rc)));
  return {};
}

MqttSession::Event MqttSession::loop(int timeout_ms) {
  if (!m_) return Event::kNone;
  const int rc = mosquitto_loop(m_, timeout_ms, 1);
  if (rc != MOSQ_ERR_SUCCESS && pending_ == Event::kNone) {
    error_ = rc == MOSQ_ERR_ERRNO ? std::string(std::strerror(errno)) : std::string(mosquitto_strerror(rc));
    if (rc == MOSQ_ERR_CONN_LOST || rc == MOSQ_ERR_NO_CONN || rc == MOSQ_ERR_ERRNO || rc == MOSQ_ERR_PROTOCOL ||
        rc == MOSQ_ERR_KEEPALIVE || rc == MOSQ_ERR_TLS) {
      up_ = false;
      pending_ = Event::kDown;
    }
  }
  const Event e = pending_;
  pending_ = Event::kNone;
  return e;
}

void MqttSession::on_connect(mosquitto*, void* self, int rc) {
  auto* s = static_cast<MqttSession*>(self);
  if (rc == 0) {
    s->up_ = true;
    s->pending_ = Event::kUp;
  } else {
    s->error_ = fmt::format("the broker refused the connection: {}", mosquitto_connack_string(rc));
    s->pending_ = Event::kRefused;
  }
}

void MqttSession::on_disconnect(mosquitto*, void* self, int rc) {
  auto* s = static_cast<MqttSession*>(self);
  if (s->up_ || rc != 0) {
    if (rc != 0 && s->error_.empty()) s->error_ = fmt::format("connection lost ({})", mosquitto_strerror(rc));
    s->up_ = false;
    s->pending_ = Event::kDown;
  }
}

void MqttSession::on_message(mosquitto*, void* self, const mosquitto_message* m) {
  auto* s = static_cast<MqttSession*>(self);
  if (s->inbox_.size() >= 10000) return;  // a flood: what the loop cannot take is not kept
  s->inbox_.push_back(Message{m->topic ? m->topic : "",
                              std::string(static_cast<const char*>(m->payload), static_cast<size_t>(std::max(0, m->payloadlen))),
                              m->retain});
}

std::vector<MqttSession::Message> MqttSession::take_messages() {
  std::vector<Message> out;
  out.swap(inbox_);
  return out;
}

bool MqttSession::publish(const std::string& topic, std::string_view payload, int qos, bool retain) {
  if (!m_ || !up_) return false;
  const int rc = mosquitto_publish(m_, nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), qos, retain);
  if (rc != MOSQ_ERR_SUCCESS) error_ = mosquitto_strerror(rc);
  return rc == MOSQ_ERR_SUCCESS;
}

bool MqttSession::subscribe(const std::string& topic, int qos) {
  if (!m_ || !up_) return false;
  if (s_.mqtt5) {
    return mosquitto_subscribe_v5(m_, nullptr, topic.c_str(), qos, MQTT_SUB_OPT_RETAIN_AS_PUBLISHED, nullptr) ==
           MOSQ_ERR_SUCCESS;
  }
  return mosquitto_subscribe(m_, nullptr, topic.c_str(), qos) == MOSQ_ERR_SUCCESS;
}

bool MqttSession::busy() const { return m_ && mosquitto_want_write(m_); }

void MqttSession::disconnect() {
  if (!m_) return;
  if (up_) {
    // Let what is queued (the NDEATH) go out before the DISCONNECT.
    for (int i = 0; i < 50 && mosquitto_want_write(m_); ++i) mosquitto_loop(m_, 10, 1);
    mosquitto_disconnect(m_);
    for (int i = 0; i < 20 && mosquitto_want_write(m_); ++i) mosquitto_loop(m_, 10, 1);
  }
  up_ = false;
}

}  // namespace rtplc::sparkplug
