// `rtplc sparkplug ...`: commissioning a plant's Sparkplug traffic, like
// candump for CAN. `listen` decodes every Sparkplug message on a broker (one
// group or all) into lines; `command` sends an NCMD rebirth or a DCMD write
// as a host application would, to try a node's `writable` set-points.
#include "io/drivers/sparkplug/cli.h"

#include <signal.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <atomic>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "common/exit_codes.h"
#include "io/drivers/sparkplug/mqtt_session.h"
#include "io/drivers/sparkplug/payload.h"
#include "kernel_rt/clock.h"

namespace rtplc::sparkplug {
namespace {

std::atomic<bool> g_interrupted{false};
void on_signal(int) { g_interrupted.store(true); }

[[noreturn]] void fail(int code, const std::string& msg) {
  std::fprintf(stderr, "rtplc sparkplug: %s\n", msg.c_str());
  throw CLI::RuntimeError(code);
}

SparkplugSettings broker_settings(const std::string& broker, const std::string& user, const std::string& password,
                                  const std::string& ca) {
  SparkplugSettings s;
  std::string why;
  if (!parse_broker(broker, s, why)) {
    fail(kExitUsage, "BROKER '" + broker + "': " + why + " (host[:port] or mqtt(s)://host[:port])");
  }
  s.username = user;
  s.password = password;
  s.ca_file = ca;
  return s;
}

// Connects and waits for the CONNACK (at most 5 s).
void open_session(MqttSession& m, const SparkplugSettings& s) {
  if (auto r = m.connect("", "", 0); !r) fail(kExitFailure, r.error());
  const int64_t give_up = kernel_rt::monotonic_now_ns() + 5 * kernel_rt::kNsPerSec;
  while (!m.up()) {
    const MqttSession::Event e = m.loop(50);
    if (e == MqttSession::Event::kRefused || e == MqttSession::Event::kDown) {
      fail(kExitFailure, fmt::format("{}: {}", s.broker_text(), m.error()));
    }
    if (kernel_rt::monotonic_now_ns() > give_up) fail(kExitFailure, s.broker_text() + ": no answer from the broker in 5 s");
  }
}

std::string clock_text() {
  const int64_t ns = kernel_rt::realtime_now_ns();
  const time_t secs = static_cast<time_t>(ns / kernel_rt::kNsPerSec);
  tm t{};
  localtime_r(&secs, &t);
  return fmt::format("{:02}:{:02}:{:02}.{:03}", t.tm_hour, t.tm_min, t.tm_sec, (ns / kernel_rt::kNsPerMs) % 1000);
}

struct ListenOptions {
  std::string broker = "127.0.0.1:1883";
  std::string group;
  std::string user, password, ca;
  int count = 0;
  double seconds = 0;
  bool quiet_properties = false;
};

void run_listen(const ListenOptions& o) {
  const SparkplugSettings s = broker_settings(o.broker, o.user, o.password, o.ca);
  MqttSession m(s, fmt::format("rtplc-listen-{}", ::getpid()));
  open_session(m, s);
  const std::string filter = o.group.empty() ? "spBv1.0/#" : "spBv1.0/" + o.group + "/#";
  m.subscribe(filter, 0);
  if (!o.group.empty()) m.subscribe("spBv1.0/STATE/#", 0);
  std::fprintf(stderr, "listening on %s for %s (Ctrl-C ends)\n", s.broker_text().c_str(), filter.c_str());
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  const int64_t end = o.seconds > 0 ? kernel_rt::monotonic_now_ns() + static_cast<int64_t>(o.seconds * 1e9) : 0;
  int seen = 0;
  while (!g_interrupted.load()) {
    if (end && kernel_rt::monotonic_now_ns() > end) break;
    const MqttSession::Event e = m.loop(100);
    if (e == MqttSession::Event::kDown) fail(kExitFailure, s.broker_text() + ": " + m.error());
    for (const MqttSession::Message& msg : m.take_messages()) {
      std::string body;
      if (msg.topic.rfind("spBv1.0/STATE/", 0) == 0) {
        body = msg.payload;  // JSON (Sparkplug 3.0)
      } else {
        Payload p;
        if (p.ParseFromString(msg.payload)) {
          body = describe_payload(p, !o.quiet_properties);
        } else {
          body = fmt::format("(not a Sparkplug B payload: {} bytes)", msg.payload.size());
        }
      }
      std::printf("%s %s%s %s\n", clock_text().c_str(), msg.topic.c_str(), msg.retained ? " (retained)" : "",
                  body.c_str());
      std::fflush(stdout);
      if (o.count > 0 && ++seen >= o.count) return;
    }
  }
}

struct CommandOptions {
  std::string broker = "127.0.0.1:1883";
  std::string target;  // GROUP/NODE or GROUP/NODE/DEVICE
  std::vector<std::string> writes;  // NAME=VALUE
  bool rebirth = false;
  std::string user, password, ca;
};

void run_command(const CommandOptions& o) {
  std::vector<std::string> parts;
  for (size_t a = 0;;) {
    const size_t b = o.target.find('/', a);
    parts.push_back(o.target.substr(a, b == std::string::npos ? std::string::npos : b - a));
    if (b == std::string::npos) break;
    a = b + 1;
  }
  if (parts.size() < 2 || parts.size() > 3) fail(kExitUsage, "TARGET is GROUP/NODE (NCMD) or GROUP/NODE/DEVICE (DCMD)");
  Payload p;
  p.set_timestamp(static_cast<uint64_t>(kernel_rt::realtime_now_ns() / kernel_rt::kNsPerMs));
  if (parts.size() == 2) {
    if (!o.rebirth || !o.writes.empty()) fail(kExitUsage, "a node takes --rebirth; writes go to GROUP/NODE/DEVICE");
    Metric* m = p.add_metrics();
    m->set_name("Node Control/Rebirth");
    set_bool(*m, true);
  } else {
    if (o.writes.empty()) fail(kExitUsage, "give NAME=VALUE for each metric to write");
    for (const std::string& w : o.writes) {
      const size_t eq = w.find('=');
      if (eq == std::string::npos || eq == 0) fail(kExitUsage, "'" + w + "' is not NAME=VALUE");
      Metric* m = p.add_metrics();
      m->set_name(w.substr(0, eq));
      const std::string v = w.substr(eq + 1);
      if (v == "true" || v == "false") {
        set_bool(*m, v == "true");
      } else {
        try {
          size_t used = 0;
          const double d = std::stod(v, &used);
          if (used != v.size()) throw std::invalid_argument(v);
          m->set_datatype(static_cast<uint32_t>(DataType::kDouble));
          m->set_double_value(d);
        } catch (const std::exception&) {
          fail(kExitUsage, "'" + v + "' is not a number, true or false");
        }
      }
    }
  }
  const SparkplugSettings s = broker_settings(o.broker, o.user, o.password, o.ca);
  MqttSession m(s, fmt::format("rtplc-command-{}", ::getpid()));
  open_session(m, s);
  const std::string topic = parts.size() == 2 ? fmt::format("spBv1.0/{}/NCMD/{}", parts[0], parts[1])
                                              : fmt::format("spBv1.0/{}/DCMD/{}/{}", parts[0], parts[1], parts[2]);
  if (!m.publish(topic, p.SerializeAsString(), 1, false)) fail(kExitFailure, "cannot publish: " + m.error());
  m.disconnect();
  std::printf("sent %s: %s\n", topic.c_str(), describe_payload(p, false).c_str());
}

void add_broker_options(CLI::App* c, std::string& user, std::string& password, std::string& ca) {
  c->add_option("--username", user, "MQTT user name");
  c->add_option("--password", password, "MQTT password");
  c->add_option("--ca", ca, "TLS (mqtts://): the CA certificate of the broker");
}

}  // namespace

void add_commands(CLI::App& app) {
  CLI::App* sp = app.add_subcommand("sparkplug", "Sparkplug B commissioning: listen to a plant, send commands");
  sp->require_subcommand(1);

  static ListenOptions lo;
  auto* listen = sp->add_subcommand("listen", "decode every Sparkplug message on a broker, one per line (like candump)");
  listen->add_option("BROKER", lo.broker, "host[:port] or mqtt(s)://host[:port]")->default_val("127.0.0.1:1883");
  listen->add_option("--group", lo.group, "only this Sparkplug group (and every host's STATE)");
  listen->add_option("--count", lo.count, "stop after this many messages")->check(CLI::Range(0, 100000000));
  listen->add_option("--seconds", lo.seconds, "stop after this long")->check(CLI::Range(0.0, 1e7));
  listen->add_flag("--no-properties", lo.quiet_properties, "leave out each metric's Quality and Forced");
  add_broker_options(listen, lo.user, lo.password, lo.ca);
  listen->footer(
      "Each line: local time, topic, seq, timestamp and the metrics (name or alias, datatype, value,\n"
      "is_historical, Quality with Ignition's code name). Example:\n"
      "  rtplc sparkplug listen 127.0.0.1:1883 --group Plant1\n");
  listen->callback([] { run_listen(lo); });

  static CommandOptions co;
  auto* command = sp->add_subcommand("command", "send a host's NCMD (rebirth) or DCMD (writes) to an edge node");
  command->add_option("TARGET", co.target, "GROUP/NODE for --rebirth, GROUP/NODE/DEVICE for writes")->required();
  command->add_option("WRITES", co.writes, "NAME=VALUE per metric (a number, true or false)");
  command->add_option("--broker", co.broker, "host[:port] or mqtt(s)://host[:port]")->default_val("127.0.0.1:1883");
  command->add_flag("--rebirth", co.rebirth, "ask the node for NBIRTH and every DBIRTH again");
  add_broker_options(command, co.user, co.password, co.ca);
  command->footer(
      "Examples:\n"
      "  rtplc sparkplug command Plant1/rtplc-01 --rebirth\n"
      "  rtplc sparkplug command Plant1/rtplc-01/loop1 Setpoint=42.5\n"
      "The node writes only the set-points its config lists in `writable`; anything else it refuses\n"
      "and logs. Sparkplug has no answer to a command: watch the node's DDATA (listen) or its log.\n");
  command->callback([] { run_command(co); });
}

}  // namespace rtplc::sparkplug
