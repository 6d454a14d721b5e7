// The blocking one-PLC client (see session.h).
#include "io/drivers/s7/session.h"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <array>
#include <cerrno>
#include <chrono>

namespace rtplc::s7 {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left < 0 ? 0 : static_cast<int>(left);
}

}  // namespace

Result<void> Session::connect(const SessionOptions& opt) {
  close();
  opt_ = opt;
  auto ep = resolve_endpoint(opt.host, opt.port);
  if (!ep) return make_error(ep.error());
  info_ = {};
  info_.endpoint = *ep;
  const auto t0 = Clock::now();
  auto fd = start_connect(*ep);
  if (!fd) return make_error(fd.error());
  fd_ = std::move(*fd);
  pollfd p{fd_.get(), POLLOUT, 0};
  const int n = ::poll(&p, 1, opt.connect_timeout_ms);
  if (n == 0) {
    close();
    return make_error(fmt::format("no answer from {} within {} ms (host down, firewalled, or wrong address)",
                                  ep->text(), opt.connect_timeout_ms));
  }
  if (n < 0) return make_error(fmt::format("poll: {}", errno_text(errno)));
  if (const int err = connect_error(fd_.get()); err != 0) {
    close();
    return make_error(fmt::format("cannot connect to {}: {}", ep->text(), errno_text(err)));
  }
  info_.tcp_connect_ms = ms_since(t0);
  const auto t1 = Clock::now();
  conn_ = Connection(opt.connection);
  conn_.open();
  if (auto r = pump_until_ready(); !r) {
    close();
    return r;
  }
  info_.setup_ms = ms_since(t1);
  info_.negotiated = conn_.negotiated();
  return {};
}

void Session::close() {
  fd_.reset();
  conn_.reset();
}

Result<void> Session::flush() {
  const auto deadline = Clock::now() + std::chrono::milliseconds(opt_.reply_timeout_ms);
  while (!conn_.outbox().empty()) {
    ByteSpan out = conn_.outbox();
    const ssize_t n = ::send(fd_.get(), out.data(), out.size(), MSG_NOSIGNAL);
    if (n > 0) {
      conn_.consume_outbox(static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      return make_error(fmt::format("send to {}: {}", info_.endpoint.text(), errno_text(errno)));
    }
    pollfd p{fd_.get(), POLLOUT, 0};
    if (::poll(&p, 1, remaining_ms(deadline)) == 0) return make_error("send timed out");
  }
  return {};
}

Result<void> Session::pump_until_ready() {
  const auto deadline = Clock::now() + std::chrono::milliseconds(opt_.connect_timeout_ms);
  std::array<uint8_t, 4096> buf{};
  Connection::Reply reply;
  while (true) {
    if (auto r = flush(); !r) return r;
    const auto e = conn_.next_event(reply);
    if (e == Connection::Event::kReady) return {};
    if (e == Connection::Event::kFailed) return make_error(conn_.error());
    if (e != Connection::Event::kNone) continue;
    if (!conn_.outbox().empty()) continue;
    pollfd p{fd_.get(), POLLIN, 0};
    const int left = remaining_ms(deadline);
    if (left == 0 || ::poll(&p, 1, left) == 0) {
      return make_error(fmt::format(
          "{} accepted TCP but did not complete the S7 handshake within {} ms (not an S7 device, or wrong TSAP)",
          info_.endpoint.text(), opt_.connect_timeout_ms));
    }
    const ssize_t n = ::recv(fd_.get(), buf.data(), buf.size(), 0);
    if (n == 0) {
      return make_error(fmt::format("{} closed the connection during the handshake (wrong rack/slot or TSAP?)",
                                    info_.endpoint.text()));
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      return make_error(fmt::format("recv from {}: {}", info_.endpoint.text(), errno_text(errno)));
    }
    conn_.feed(ByteSpan(buf.data(), static_cast<size_t>(n)));
  }
}

Result<Connection::Reply> Session::await_reply(uint16_t ref) {
  if (auto r = flush(); !r) return make_error(r.error());
  const auto deadline = Clock::now() + std::chrono::milliseconds(opt_.reply_timeout_ms);
  std::array<uint8_t, 4096> buf{};
  Connection::Reply reply;
  while (true) {
    const auto e = conn_.next_event(reply);
    if (e == Connection::Event::kReply && reply.pdu_ref == ref) return reply;
    if (e == Connection::Event::kFailed) return make_error(conn_.error());
    if (e != Connection::Event::kNone) continue;
    pollfd p{fd_.get(), POLLIN, 0};
    const int left = remaining_ms(deadline);
    if (left == 0 || ::poll(&p, 1, left) == 0) {
      conn_.fail("reply timeout");
      return make_error(fmt::format("no reply from {} within {} ms", info_.endpoint.text(), opt_.reply_timeout_ms));
    }
    const ssize_t n = ::recv(fd_.get(), buf.data(), buf.size(), 0);
    if (n == 0) {
      conn_.fail("closed");
      return make_error(fmt::format("{} closed the connection", info_.endpoint.text()));
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      return make_error(fmt::format("recv from {}: {}", info_.endpoint.text(), errno_text(errno)));
    }
    conn_.feed(ByteSpan(buf.data(), static_cast<size_t>(n)));
  }
}

Result<std::vector<ItemOutcome>> Session::read(std::span<const ItemAddress> items) {
  if (!connected()) return make_error("not connected");
  PlanLimits lim;
  lim.pdu = conn_.negotiated().pdu_size;
  auto plan = plan_reads(items, lim);
  if (!plan) return make_error(plan.error());
  std::vector<ItemOutcome> out(items.size());
  const auto frames = encode_read_frames(*plan);
  // One request at a time keeps this simple; the engine is where pipelining pays.
  for (uint32_t r = 0; r < frames.size(); ++r) {
    auto ref = conn_.send_job(r, frames[r]);
    if (!ref) return make_error(ref.error());
    auto reply = await_reply(*ref);
    if (!reply) return make_error(reply.error());
    auto ok = apply_read_reply(*plan, items, r, reply->header, scratch_, [&](uint32_t idx, const ItemResult& res) {
      out[idx].return_code = res.return_code;
      out[idx].raw = res.raw;
    });
    if (!ok) return make_error(ok.error());
  }
  return out;
}

Result<std::vector<ItemOutcome>> Session::write(std::span<const ItemAddress> items, std::span<const uint64_t> raws) {
  if (!connected()) return make_error("not connected");
  if (raws.size() != items.size()) return make_error("one value per item");
  PlanLimits lim;
  lim.pdu = conn_.negotiated().pdu_size;
  auto plan = plan_writes(items, lim);
  if (!plan) return make_error(plan.error());
  std::vector<ItemOutcome> out(items.size());
  Bytes frame;
  std::vector<uint8_t> codes;
  for (const PlannedWrite& w : *plan) {
    frame.clear();
    encode_write_frame(frame, items, raws, w.items);
    auto ref = conn_.send_job(0, frame);
    if (!ref) return make_error(ref.error());
    auto reply = await_reply(*ref);
    if (!reply) return make_error(reply.error());
    if (auto ok = parse_write_reply(reply->header, w.items.size(), codes); !ok) return make_error(ok.error());
    for (size_t i = 0; i < w.items.size(); ++i) {
      out[w.items[i]].return_code = codes[i];
      out[w.items[i]].raw = raws[w.items[i]];
    }
  }
  return out;
}

Result<double> Session::ping_ms() {
  if (!connected()) return make_error("not connected");
  ItemAddress mb0;
  mb0.area = Area::kFlags;
  const VarSpec v = var_spec_for(mb0);
  const auto t0 = Clock::now();
  auto ref = conn_.send_read(0, std::span<const VarSpec>(&v, 1));
  if (!ref) return make_error(ref.error());
  auto reply = await_reply(*ref);
  if (!reply) return make_error(reply.error());
  return ms_since(t0);
}

}  // namespace rtplc::s7
