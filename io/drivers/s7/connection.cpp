// The S7 connection state machine (spec: s7-client.md, "Protocol" and "The engine
// we want"). See connection.h for the states.
#include "io/drivers/s7/connection.h"

#include <fmt/format.h>

#include <algorithm>

namespace rtplc::s7 {

Connection::Connection(ConnectionConfig cfg) : cfg_(cfg) {
  in_flight_.reserve(kMaxInFlight);
  out_.reserve(1024);
  in_.reserve(2048);
}

void Connection::open() {
  reset();
  encode_connection_request(out_, cfg_.local_tsap, cfg_.remote_tsap);
  state_ = State::kAwaitConfirm;
}

void Connection::reset() {
  state_ = State::kIdle;
  error_.clear();
  negotiated_ = {};
  max_in_flight_ = 1;
  in_flight_.clear();
  out_.clear();
  out_pos_ = 0;
  in_.clear();
  in_pos_ = 0;
  fragments_.clear();
}

void Connection::consume_outbox(size_t n) {
  out_pos_ = std::min(out_.size(), out_pos_ + n);
  if (out_pos_ == out_.size()) {
    out_.clear();
    out_pos_ = 0;
  }
}

void Connection::compact() {
  if (in_pos_ == 0) return;
  if (in_pos_ >= in_.size()) {
    in_.clear();
  } else {
    in_.erase(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(in_pos_));
  }
  in_pos_ = 0;
}

void Connection::feed(ByteSpan bytes) {
  if (state_ == State::kFailed || state_ == State::kIdle) return;
  compact();
  in_.insert(in_.end(), bytes.begin(), bytes.end());
}

Connection::Event Connection::failed(std::string message) {
  if (state_ == State::kFailed) return Event::kNone;
  state_ = State::kFailed;
  error_ = std::move(message);
  in_flight_.clear();
  return Event::kFailed;
}

void Connection::fail(std::string message) { (void)failed(std::move(message)); }

uint16_t Connection::next_ref() {
  ++ref_counter_;
  if (ref_counter_ == 0) ref_counter_ = 1;
  return ref_counter_;
}

Connection::Event Connection::next_event(Reply& reply) {
  while (state_ != State::kFailed && state_ != State::kIdle) {
    ByteSpan avail = ByteSpan(in_).subspan(in_pos_);
    auto len = tpkt_frame_length(avail);
    if (!len) return failed(len.error());
    if (*len == 0) return Event::kNone;
    ByteSpan frame = avail.first(*len);
    in_pos_ += *len;
    const Event e = handle_frame(frame, reply);
    if (e != Event::kNone) return e;
  }
  return Event::kNone;
}

Connection::Event Connection::handle_frame(ByteSpan frame, Reply& reply) {
  auto tpdu = parse_frame(frame);
  if (!tpdu) return failed(tpdu.error());
  switch (tpdu->type) {
    case CotpType::kConnectionConfirm: {
      if (state_ != State::kAwaitConfirm) return failed("unexpected COTP connection confirm");
      setup_ref_ = next_ref();
      encode_setup_request(out_, setup_ref_, cfg_.setup);
      state_ = State::kAwaitSetup;
      return Event::kNone;
    }
    case CotpType::kDisconnectRequest:
    case CotpType::kError:
      if (state_ == State::kAwaitConfirm) {
        return failed(fmt::format(
            "the PLC refused the connection (COTP {} reason 0x{:02X}): check the rack/slot (--rack/--slot) or the TSAPs",
            tpdu->type == CotpType::kError ? "error" : "disconnect", tpdu->reason));
      }
      return failed(fmt::format("the PLC closed the connection (COTP reason 0x{:02X})", tpdu->reason));
    case CotpType::kData: {
      if (state_ == State::kAwaitConfirm) return failed("data before the COTP connection was confirmed");
      if (!tpdu->last) {
        if (fragments_.size() + tpdu->payload.size() > kMaxFrame) return failed("fragmented PDU too large");
        fragments_.insert(fragments_.end(), tpdu->payload.begin(), tpdu->payload.end());
        return Event::kNone;
      }
      if (!fragments_.empty()) {
        fragments_.insert(fragments_.end(), tpdu->payload.begin(), tpdu->payload.end());
        assembled_.swap(fragments_);
        fragments_.clear();
        return handle_s7(assembled_, reply);
      }
      return handle_s7(tpdu->payload, reply);
    }
    default:
      return failed(fmt::format("unexpected COTP TPDU 0x{:02X}", static_cast<unsigned>(tpdu->type)));
  }
}

Connection::Event Connection::handle_s7(ByteSpan payload, Reply& reply) {
  auto h = parse_s7(payload);
  if (!h) return failed(h.error());
  if (state_ == State::kAwaitSetup) {
    if (h->pdu_ref != setup_ref_) return failed("setup communication answered with a wrong PDU reference");
    auto p = parse_setup(*h);
    if (!p) return failed(fmt::format("setup communication refused: {}", p.error()));
    if (p->pdu_size < 64) return failed(fmt::format("the PLC granted a PDU of {} bytes, too small", p->pdu_size));
    negotiated_ = *p;
    // The PLC may grant less than we asked but never more counts.
    negotiated_.pdu_size = std::min(p->pdu_size, cfg_.setup.pdu_size);
    max_in_flight_ = std::clamp<size_t>(std::min(p->amq_calling, cfg_.setup.amq_calling), 1, kMaxInFlight);
    state_ = State::kReady;
    return Event::kReady;
  }
  if (h->rosctr != kRosctrAckData && h->rosctr != kRosctrAck) {
    ++dropped_;  // jobs or user data from the PLC: nothing we asked for
    return Event::kNone;
  }
  auto it = std::find_if(in_flight_.begin(), in_flight_.end(), [&](const InFlight& f) { return f.ref == h->pdu_ref; });
  if (it == in_flight_.end()) {
    ++dropped_;
    return Event::kNone;
  }
  reply.cookie = it->cookie;
  reply.pdu_ref = it->ref;
  reply.header = *h;
  in_flight_.erase(it);
  return Event::kReply;
}

Result<uint16_t> Connection::send_job(uint32_t cookie, ByteSpan frame) {
  if (state_ != State::kReady) return make_error("connection not ready");
  if (in_flight_.size() >= max_in_flight_) return make_error("no free job slot (AmQ exhausted)");
  if (frame.size() < kFramePduRefOffset + 2) return make_error("job frame too short");
  const uint16_t ref = next_ref();
  const size_t at = out_.size();
  out_.insert(out_.end(), frame.begin(), frame.end());
  patch_pdu_ref(std::span<uint8_t>(out_).subspan(at), ref);
  in_flight_.push_back({ref, cookie});
  return ref;
}

Result<uint16_t> Connection::send_read(uint32_t cookie, std::span<const VarSpec> vars) {
  scratch_.clear();
  encode_read_request(scratch_, 0, vars);
  return send_job(cookie, scratch_);
}

Result<uint16_t> Connection::send_write(uint32_t cookie, std::span<const VarSpec> vars,
                                        std::span<const ByteSpan> values) {
  scratch_.clear();
  encode_write_request(scratch_, 0, vars, values);
  return send_job(cookie, scratch_);
}

void Connection::forget(uint16_t pdu_ref) {
  auto it = std::find_if(in_flight_.begin(), in_flight_.end(), [&](const InFlight& f) { return f.ref == pdu_ref; });
  if (it != in_flight_.end()) in_flight_.erase(it);
}

}  // namespace rtplc::s7
