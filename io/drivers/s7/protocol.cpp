// Encoders and bounds-checked decoders of TPKT, COTP and the S7 PDUs
// (spec: s7-client.md, "Protocol"). Every decoder checks a length field against the
// bytes that are really there before it trusts it.
#include "io/drivers/s7/protocol.h"

#include <fmt/format.h>

namespace rtplc::s7 {
namespace {

void put8(Bytes& out, unsigned v) { out.push_back(static_cast<uint8_t>(v & 0xFF)); }
void put16(Bytes& out, unsigned v) {
  out.push_back(static_cast<uint8_t>((v >> 8) & 0xFF));
  out.push_back(static_cast<uint8_t>(v & 0xFF));
}
uint16_t get16(ByteSpan b, size_t at) { return static_cast<uint16_t>(b[at] << 8 | b[at + 1]); }

// Bytes in a data item whose length field says `len` in the unit its size implies.
Result<size_t> data_item_bytes(DataSize size, uint16_t len) {
  switch (size) {
    case DataSize::kNull:
    case DataSize::kReal:
    case DataSize::kOctetString:
      return static_cast<size_t>(len);
    case DataSize::kBit:
      // A bit travels as one byte; some servers put 1 (bits), others 1 (byte).
      return static_cast<size_t>(len == 0 ? 0 : (len + 7) / 8);
    case DataSize::kByte:
    case DataSize::kInteger:
      return static_cast<size_t>((len + 7) / 8);
  }
  return make_error(fmt::format("unknown data transport size 0x{:02X}", static_cast<unsigned>(size)));
}

bool known_data_size(uint8_t v) {
  return v == 0x00 || v == 0x03 || v == 0x04 || v == 0x05 || v == 0x07 || v == 0x09;
}

uint16_t encode_data_len(DataSize size, size_t bytes) {
  switch (size) {
    case DataSize::kBit:
      return 1;
    case DataSize::kByte:
    case DataSize::kInteger:
      return static_cast<uint16_t>(bytes * 8);
    default:
      return static_cast<uint16_t>(bytes);
  }
}

void encode_var(Bytes& out, const VarSpec& v) {
  put8(out, 0x12);  // variable specification
  put8(out, 0x0A);  // length of the rest
  put8(out, 0x10);  // syntax id: S7ANY
  put8(out, static_cast<unsigned>(v.ts));
  put16(out, v.count);
  put16(out, v.db);
  put8(out, static_cast<unsigned>(v.area));
  put8(out, (v.address >> 16) & 0xFF);
  put8(out, (v.address >> 8) & 0xFF);
  put8(out, v.address & 0xFF);
}

}  // namespace

uint16_t remote_tsap(ConnectionType type, unsigned rack, unsigned slot) {
  return static_cast<uint16_t>(static_cast<unsigned>(type) << 8 | ((rack * 32 + slot) & 0xFF));
}

void encode_connection_request(Bytes& out, uint16_t local_tsap, uint16_t remote) {
  const size_t start = out.size();
  put8(out, 3);
  put8(out, 0);
  put16(out, 0);  // patched below
  put8(out, 17);    // COTP length indicator
  put8(out, 0xE0);  // CR
  put16(out, 0);    // dst ref
  put16(out, 1);    // src ref
  put8(out, 0);     // class 0
  put8(out, 0xC0);  // TPDU size 1024
  put8(out, 1);
  put8(out, 0x0A);
  put8(out, 0xC1);  // calling TSAP
  put8(out, 2);
  put16(out, local_tsap);
  put8(out, 0xC2);  // called TSAP
  put8(out, 2);
  put16(out, remote);
  patch_tpkt_length(out, start);
}

Result<size_t> tpkt_frame_length(ByteSpan buf) {
  if (buf.size() < kTpktHeader) return size_t{0};
  if (buf[0] != 3) return make_error(fmt::format("not a TPKT frame (version byte 0x{:02X}, want 0x03)", buf[0]));
  const size_t len = get16(buf, 2);
  if (len < kTpktHeader + 2) return make_error(fmt::format("TPKT length {} is shorter than a COTP header", len));
  if (len > kMaxFrame) return make_error(fmt::format("TPKT length {} exceeds the largest frame ({})", len, kMaxFrame));
  return buf.size() >= len ? len : size_t{0};
}

Result<CotpTpdu> parse_frame(ByteSpan frame) {
  auto flen = tpkt_frame_length(frame);
  if (!flen) return make_error(flen.error());
  if (*flen == 0 || *flen != frame.size()) return make_error("incomplete TPKT frame");
  const size_t li = frame[4];
  const size_t hdr_end = 5 + li;
  if (li < 2 || hdr_end > frame.size()) {
    return make_error(fmt::format("COTP length indicator {} does not fit a {}-byte frame", li, frame.size()));
  }
  CotpTpdu t;
  const uint8_t code = frame[5] & 0xF0;
  switch (code) {
    case 0xF0: {
      t.type = CotpType::kData;
      t.last = (frame[6] & 0x80) != 0;
      t.payload = frame.subspan(hdr_end);
      return t;
    }
    case 0xE0:
    case 0xD0: {
      t.type = code == 0xE0 ? CotpType::kConnectionRequest : CotpType::kConnectionConfirm;
      if (li < 6) return make_error("COTP connection TPDU too short");
      t.dst_ref = get16(frame, 6);
      t.src_ref = get16(frame, 8);
      size_t p = 11;
      while (p + 2 <= hdr_end) {
        const uint8_t pc = frame[p];
        const size_t plen = frame[p + 1];
        if (p + 2 + plen > hdr_end) return make_error("COTP parameter runs past its header");
        ByteSpan v = frame.subspan(p + 2, plen);
        if (pc == 0xC0 && plen == 1 && v[0] >= 7 && v[0] <= 13) t.tpdu_size = static_cast<uint16_t>(1u << v[0]);
        if (pc == 0xC1 && plen >= 2) t.calling_tsap = get16(v, 0);
        if (pc == 0xC2 && plen >= 2) t.called_tsap = get16(v, 0);
        p += 2 + plen;
      }
      return t;
    }
    case 0x80:
    case 0xC0: {
      t.type = code == 0x80 ? CotpType::kDisconnectRequest : CotpType::kDisconnectConfirm;
      if (li >= 6) {
        t.dst_ref = get16(frame, 6);
        t.src_ref = get16(frame, 8);
      }
      if (code == 0x80 && li >= 6 && hdr_end > 10) t.reason = frame[10];
      return t;
    }
    case 0x70: {
      t.type = CotpType::kError;
      if (li >= 4) t.reason = frame[8];
      return t;
    }
    default:
      return make_error(fmt::format("unknown COTP TPDU type 0x{:02X}", frame[5]));
  }
}

Result<S7Header> parse_s7(ByteSpan p) {
  if (p.size() < kS7JobHeader) return make_error(fmt::format("S7 header needs 10 bytes, got {}", p.size()));
  if (p[0] != 0x32) return make_error(fmt::format("not an S7 PDU (protocol id 0x{:02X}, want 0x32)", p[0]));
  S7Header h;
  h.rosctr = p[1];
  size_t hl = kS7JobHeader;
  if (h.rosctr == kRosctrAck || h.rosctr == kRosctrAckData) {
    hl = kS7AckHeader;
    if (p.size() < hl) return make_error("S7 ack header truncated");
    h.error_class = p[10];
    h.error_code = p[11];
  } else if (h.rosctr != kRosctrJob && h.rosctr != kRosctrUserData) {
    return make_error(fmt::format("unknown S7 PDU type (ROSCTR 0x{:02X})", h.rosctr));
  }
  h.pdu_ref = get16(p, 4);
  const size_t plen = get16(p, 6);
  const size_t dlen = get16(p, 8);
  if (hl + plen + dlen > p.size()) {
    return make_error(fmt::format("S7 lengths (parameters {}, data {}) exceed the {} bytes received", plen, dlen,
                                  p.size() - hl));
  }
  h.params = p.subspan(hl, plen);
  h.data = p.subspan(hl + plen, dlen);
  return h;
}

namespace {
void encode_frame_start(Bytes& out) {
  put8(out, 3);
  put8(out, 0);
  put16(out, 0);
  put8(out, 2);  // COTP DT: length indicator
  put8(out, 0xF0);
  put8(out, 0x80);  // last data unit
}
}  // namespace

void encode_job_header(Bytes& out, uint16_t pdu_ref, uint16_t param_len, uint16_t data_len) {
  encode_frame_start(out);
  put8(out, 0x32);
  put8(out, kRosctrJob);
  put16(out, 0);
  put16(out, pdu_ref);
  put16(out, param_len);
  put16(out, data_len);
}

void encode_ack_header(Bytes& out, uint8_t rosctr, uint16_t pdu_ref, uint16_t param_len, uint16_t data_len,
                       uint16_t error) {
  encode_frame_start(out);
  put8(out, 0x32);
  put8(out, rosctr);
  put16(out, 0);
  put16(out, pdu_ref);
  put16(out, param_len);
  put16(out, data_len);
  put16(out, error);
}

void patch_tpkt_length(Bytes& out, size_t frame_start) {
  const size_t len = out.size() - frame_start;
  out[frame_start + 2] = static_cast<uint8_t>(len >> 8);
  out[frame_start + 3] = static_cast<uint8_t>(len & 0xFF);
}

void patch_pdu_ref(std::span<uint8_t> frame, uint16_t pdu_ref) {
  frame[kFramePduRefOffset] = static_cast<uint8_t>(pdu_ref >> 8);
  frame[kFramePduRefOffset + 1] = static_cast<uint8_t>(pdu_ref & 0xFF);
}

void encode_setup_request(Bytes& out, uint16_t pdu_ref, const SetupParams& p) {
  const size_t start = out.size();
  encode_job_header(out, pdu_ref, 8, 0);
  put8(out, kFuncSetup);
  put8(out, 0);
  put16(out, p.amq_calling);
  put16(out, p.amq_called);
  put16(out, p.pdu_size);
  patch_tpkt_length(out, start);
}

Result<SetupParams> parse_setup(const S7Header& h) {
  if (h.rosctr != kRosctrJob) {
    if (auto ok = check_ack(h, kFuncSetup, 0); !ok) return make_error(ok.error());
  }
  if (h.params.size() < 8 || h.params[0] != kFuncSetup) return make_error("malformed setup communication parameters");
  SetupParams p;
  p.amq_calling = get16(h.params, 2);
  p.amq_called = get16(h.params, 4);
  p.pdu_size = get16(h.params, 6);
  return p;
}

size_t var_data_bytes(const VarSpec& v) {
  switch (v.ts) {
    case TransportSize::kBit:
    case TransportSize::kByte:
    case TransportSize::kChar:
      return v.count;
    case TransportSize::kWord:
    case TransportSize::kInt:
    case TransportSize::kCounter:
    case TransportSize::kTimer:
      return size_t{2} * v.count;
    case TransportSize::kDWord:
    case TransportSize::kDInt:
    case TransportSize::kReal:
      return size_t{4} * v.count;
  }
  return 0;
}

DataSize data_size_for(TransportSize ts) {
  switch (ts) {
    case TransportSize::kBit:
      return DataSize::kBit;
    case TransportSize::kInt:
    case TransportSize::kDInt:
      return DataSize::kInteger;
    case TransportSize::kReal:
      return DataSize::kReal;
    case TransportSize::kChar:
    case TransportSize::kCounter:
    case TransportSize::kTimer:
      return DataSize::kOctetString;
    default:
      return DataSize::kByte;
  }
}

void encode_read_request(Bytes& out, uint16_t pdu_ref, std::span<const VarSpec> vars) {
  const size_t start = out.size();
  encode_job_header(out, pdu_ref, static_cast<uint16_t>(2 + kReadItemSize * vars.size()), 0);
  put8(out, kFuncRead);
  put8(out, static_cast<unsigned>(vars.size()));
  for (const VarSpec& v : vars) encode_var(out, v);
  patch_tpkt_length(out, start);
}

void encode_write_request(Bytes& out, uint16_t pdu_ref, std::span<const VarSpec> vars,
                          std::span<const ByteSpan> values) {
  const size_t start = out.size();
  size_t data_len = 0;
  for (size_t i = 0; i < vars.size(); ++i) {
    const size_t n = values[i].size();
    data_len += 4 + n + ((n & 1) && i + 1 < vars.size() ? 1 : 0);
  }
  encode_job_header(out, pdu_ref, static_cast<uint16_t>(2 + kReadItemSize * vars.size()),
                    static_cast<uint16_t>(data_len));
  put8(out, kFuncWrite);
  put8(out, static_cast<unsigned>(vars.size()));
  for (const VarSpec& v : vars) encode_var(out, v);
  for (size_t i = 0; i < vars.size(); ++i) {
    const DataSize ds = data_size_for(vars[i].ts);
    const size_t n = values[i].size();
    put8(out, 0);
    put8(out, static_cast<unsigned>(ds));
    put16(out, encode_data_len(ds, n));
    out.insert(out.end(), values[i].begin(), values[i].end());
    if ((n & 1) && i + 1 < vars.size()) put8(out, 0);
  }
  patch_tpkt_length(out, start);
}

Result<std::vector<VarSpec>> parse_var_params(const S7Header& h, uint8_t function) {
  if (h.params.size() < 2 || h.params[0] != function) return make_error("unexpected S7 function");
  const size_t n = h.params[1];
  if (2 + n * kReadItemSize > h.params.size()) return make_error("item count runs past the parameters");
  std::vector<VarSpec> vars;
  vars.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    ByteSpan it = h.params.subspan(2 + i * kReadItemSize, kReadItemSize);
    if (it[0] != 0x12 || it[1] != 0x0A || it[2] != 0x10) return make_error("unsupported variable specification");
    VarSpec v;
    v.ts = static_cast<TransportSize>(it[3]);
    v.count = get16(it, 4);
    v.db = get16(it, 6);
    v.area = static_cast<Area>(it[8]);
    v.address = static_cast<uint32_t>(it[9]) << 16 | static_cast<uint32_t>(it[10]) << 8 | it[11];
    vars.push_back(v);
  }
  return vars;
}

Result<void> parse_data_items(ByteSpan data, size_t count, bool with_return_code, std::vector<DataItem>& out) {
  out.clear();
  size_t p = 0;
  for (size_t i = 0; i < count; ++i) {
    if (p + 4 > data.size()) return make_error(fmt::format("data item {} of {} is missing", i + 1, count));
    DataItem d;
    d.return_code = with_return_code ? data[p] : kItemOk;
    if (!known_data_size(data[p + 1])) {
      return make_error(fmt::format("data item {}: unknown transport size 0x{:02X}", i + 1, data[p + 1]));
    }
    d.size = static_cast<DataSize>(data[p + 1]);
    auto n = data_item_bytes(d.size, get16(data, p + 2));
    if (!n) return make_error(n.error());
    // A refused item carries no data whatever its length says (snap7 puts 4 there).
    if (with_return_code && d.return_code != kItemOk && d.size == DataSize::kNull) *n = 0;
    if (p + 4 + *n > data.size()) {
      return make_error(fmt::format("data item {} claims {} bytes, only {} left", i + 1, *n, data.size() - p - 4));
    }
    d.data = data.subspan(p + 4, *n);
    p += 4 + *n;
    // Odd-length items are padded to even, except the last one.
    if ((*n & 1) && i + 1 < count) {
      if (p >= data.size()) return make_error(fmt::format("data item {}: fill byte missing", i + 1));
      ++p;
    }
    out.push_back(d);
  }
  return {};
}

Result<void> check_ack(const S7Header& h, uint8_t function, size_t count) {
  if (h.rosctr != kRosctrAckData && h.rosctr != kRosctrAck) {
    return make_error(fmt::format("expected an acknowledgement, got ROSCTR 0x{:02X}", h.rosctr));
  }
  if (h.error() != 0) return make_error(header_error_message(h.error()));
  if (h.params.size() < 2 || h.params[0] != function) {
    return make_error(fmt::format("reply is for function 0x{:02X}, want 0x{:02X}", h.params.empty() ? 0 : h.params[0],
                                  function));
  }
  if (function != kFuncSetup && h.params[1] != count) {
    return make_error(fmt::format("reply carries {} items, request had {}", h.params[1], count));
  }
  return {};
}

Result<void> parse_read_reply(const S7Header& h, size_t count, std::vector<DataItem>& out) {
  if (auto ok = check_ack(h, kFuncRead, count); !ok) return ok;
  return parse_data_items(h.data, count, true, out);
}

Result<void> parse_write_reply(const S7Header& h, size_t count, std::vector<uint8_t>& codes) {
  if (auto ok = check_ack(h, kFuncWrite, count); !ok) return ok;
  if (h.data.size() < count) return make_error(fmt::format("write reply carries {} of {} return codes", h.data.size(), count));
  codes.assign(h.data.begin(), h.data.begin() + static_cast<std::ptrdiff_t>(count));
  return {};
}

void encode_read_reply(Bytes& out, uint16_t pdu_ref, std::span<const DataItem> items) {
  const size_t start = out.size();
  size_t dlen = 0;
  for (size_t i = 0; i < items.size(); ++i) {
    const size_t n = items[i].data.size();
    dlen += 4 + n + ((n & 1) && i + 1 < items.size() ? 1 : 0);
  }
  encode_ack_header(out, kRosctrAckData, pdu_ref, 2, static_cast<uint16_t>(dlen), 0);
  put8(out, kFuncRead);
  put8(out, static_cast<unsigned>(items.size()));
  for (size_t i = 0; i < items.size(); ++i) {
    const DataItem& d = items[i];
    const size_t n = d.data.size();
    put8(out, d.return_code);
    put8(out, static_cast<unsigned>(d.size));
    put16(out, encode_data_len(d.size, n));
    out.insert(out.end(), d.data.begin(), d.data.end());
    if ((n & 1) && i + 1 < items.size()) put8(out, 0);
  }
  patch_tpkt_length(out, start);
}

void encode_write_reply(Bytes& out, uint16_t pdu_ref, std::span<const uint8_t> codes) {
  const size_t start = out.size();
  encode_ack_header(out, kRosctrAckData, pdu_ref, 2, static_cast<uint16_t>(codes.size()), 0);
  put8(out, kFuncWrite);
  put8(out, static_cast<unsigned>(codes.size()));
  out.insert(out.end(), codes.begin(), codes.end());
  patch_tpkt_length(out, start);
}

void encode_error_reply(Bytes& out, uint16_t pdu_ref, uint16_t error) {
  const size_t start = out.size();
  encode_ack_header(out, kRosctrAckData, pdu_ref, 0, 0, error);
  patch_tpkt_length(out, start);
}

const char* item_error_name(uint8_t rc) {
  const char* what = nullptr;
  switch (rc) {
    case 0xFF: what = "ok"; break;
    case 0x00: what = "reserved return code (no data)"; break;
    case 0x01: what = "hardware fault in the PLC"; break;
    case 0x03: what = "access to the object not allowed"; break;
    case 0x05: what = "address out of range (past the end of the area or DB)"; break;
    case 0x06: what = "data type not supported"; break;
    case 0x07: what = "data type inconsistent with the object"; break;
    case 0x0A: what = "object does not exist (no such DB or area)"; break;
    default: what = "unknown item error"; break;
  }
  return what;
}

std::string item_error_message(uint8_t rc) { return fmt::format("{} (0x{:02X})", item_error_name(rc), rc); }

std::string header_error_message(uint16_t error) {
  switch (error) {
    case 0x8104:
      return "the PLC does not support this service or forbids it (0x8104): on an S7-1200/1500 allow "
             "PUT/GET communication from remote partners in the CPU's protection settings";
    case 0x8500:
      return "request too large for the negotiated PDU (0x8500)";
    case 0x8304:
      return "the PLC refused the write (0x8304): check its protection level and whether the area is writable";
    case 0x8404:
      return "the PLC could not process the request: protocol error in the job (0x8404)";
    case 0x8301:
      return "the PLC has no resources for this request now (0x8301): too many parallel jobs";
    case 0x8702:
      return "access error in the PLC (0x8702)";
    default:
      break;
  }
  const char* cls = "unknown error class";
  switch (error >> 8) {
    case 0x81: cls = "application relationship error"; break;
    case 0x82: cls = "object definition error"; break;
    case 0x83: cls = "no resources available in the PLC"; break;
    case 0x84: cls = "error on service processing"; break;
    case 0x85: cls = "error on supplies"; break;
    case 0x87: cls = "access error"; break;
    default: break;
  }
  return fmt::format("{} (class 0x{:02X}, code 0x{:02X})", cls, error >> 8, error & 0xFF);
}

std::string area_name(Area a) {
  switch (a) {
    case Area::kInputs: return "inputs";
    case Area::kOutputs: return "outputs";
    case Area::kFlags: return "flags";
    case Area::kDB: return "DB";
    case Area::kCounters: return "counters";
    case Area::kTimers: return "timers";
  }
  return "unknown area";
}

}  // namespace rtplc::s7
