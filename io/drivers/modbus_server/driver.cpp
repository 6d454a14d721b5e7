// The modbus-server driver and its kind (see driver.h).
#include "io/drivers/modbus_server/driver.h"

#include <fmt/format.h>

#include <algorithm>

#include "blocks/registry.h"
#include "io/drivers/lifecycle.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus_server {

ServerDriver::ServerDriver(const io::DriverSetup& setup)
    : io::Driver(setup, "mbserver"), settings_(settings_of(*setup.config)) {}

ServerDriver::~ServerDriver() {
  request_stop();
  join();
  if (server_) server_->stop();
}

Result<void> ServerDriver::prepare() {
  const io::ProcessImage& img = *setup().image;
  std::vector<bool> writable;
  for (const ExposeItem& e : settings_.items) {
    const int c = img.find_channel(e.label);
    const std::string where = fmt::format("expose entry at line {}", e.pos.line);
    if (c < 0) {
      std::string known;
      for (uint32_t i = 0; i < img.channel_count() && i < 12; ++i) known += (i ? ", " : "") + std::string(img.channel(i).label);
      if (img.channel_count() > 12) known += ", ...";
      return make_error(fmt::format("{}: no channel is labelled \"{}\" in the tasks' programs (they have: {})", where,
                                    e.label, known));
    }
    const io::ChannelDesc& d = img.channel(static_cast<uint32_t>(c));
    const bool digital = d.kind == static_cast<uint8_t>(Kind::kDigital);
    if (modbus::is_bit_table(e.item.table) && !digital) {
      return make_error(fmt::format("{}: \"{}\" is analog; a {} carries a digital channel (use ir or hr)", where,
                                    e.label, modbus::table_name(e.item.table)));
    }
    channel_.push_back(static_cast<uint32_t>(c));
    const bool listed = std::find(settings_.writable.begin(), settings_.writable.end(), e.label) != settings_.writable.end();
    writable.push_back(listed && modbus::is_writable(e.item.table));
  }
  // Only set-points are ever written from the network.
  for (size_t i = 0; i < settings_.writable.size(); ++i) {
    const int c = img.find_channel(settings_.writable[i]);
    if (c >= 0 && img.channel(static_cast<uint32_t>(c)).dir != static_cast<uint8_t>(io::ChannelDir::kSetpoint)) {
      return make_error(fmt::format("writable entry at line {}: \"{}\" is not a set-point; only set-points are "
                                    "written from the network", settings_.writable_pos[i].line, settings_.writable[i]));
    }
  }
  auto read = [this](uint32_t item) {
    // read_channel judges the age by the one rule (io::judge_quality); a
    // reading that was not consistent is bad.
    const io::ChannelValue v = setup().image->read_channel(channel_[item]);
    return ItemReading{v.value, v.fresh ? v.quality : Quality::kBad};
  };
  auto write = [this](uint32_t item, double value) -> Result<std::string> {
    if (!setup().set_point) return make_error("no runtime behind this driver sets set-points");
    return setup().set_point(settings_.items[item].label, value);
  };
  handler_ = std::make_unique<RequestHandler>(settings_, std::move(writable), read, write);
  server_ = std::make_unique<TcpServer>(settings_, *handler_, [this](bool error, const std::string& text) {
    log(error ? io::LinkEvent::Level::kWarning : io::LinkEvent::Level::kInfo, text);
  });
  describe_link(0, name(), fmt::format("{}:{} server", settings_.bind, settings_.port));
  return {};
}

Result<void> ServerDriver::on_start() {
  // The server only moves bytes and reads the image: below every task.
  return server_->start("mbs-" + name(), setup().helper_priority, setup().cpu);
}

// The bridge thread has ended (joined): this thread may write the link row now.
void ServerDriver::on_joined() noexcept {
  server_->stop();
  publish_counters();  // the row says down, no client connected
}

// The link row of a server (docs/modbus.md, "Statistics"): state up while it
// listens; connects = clients accepted, reconnects = clients refused, timeouts
// = clients closed for silence, errors = exception answers and broken streams,
// polls completed = requests answered, polls offline = clients connected now,
// writes acked / failed = set-points changed / write requests refused.
void ServerDriver::cycle(int64_t now) noexcept {
  publish_counters();
  // Its region holds nothing; the snapshot says the driver is alive.
  end_snapshot(begin_snapshot(), now);
}

void ServerDriver::publish_counters() noexcept {
  const ServerCounters& c = server_->counters();
  const auto r = std::memory_order_relaxed;
  io::LinkStatus& ls = link_row(0);
  const bool up = c.listening.load(r);
  ls.state.store(static_cast<uint8_t>(up ? io::LinkState::kUp : io::LinkState::kDown), r);
  ls.quality.store(static_cast<uint8_t>(up ? Quality::kGood : Quality::kBad), r);
  ls.connects.store(c.accepted.load(r), r);
  ls.reconnects.store(c.refused.load(r), r);
  ls.timeouts.store(c.idle_closed.load(r), r);
  ls.errors.store(c.exceptions.load(r) + c.bad_frames.load(r), r);
  ls.polls_completed.store(c.requests.load(r), r);
  ls.polls_offline.store(c.connected.load(r), r);
  ls.writes_acked.store(c.writes_accepted.load(r), r);
  ls.writes_failed.store(c.writes_refused.load(r), r);
}

const io::DriverKind kDriverKind{&kConfigKind, &io::create_prepared<ServerDriver>, nullptr};

}  // namespace rtplc::modbus_server
