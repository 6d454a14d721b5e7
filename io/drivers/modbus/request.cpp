// Modbus TCP requests and their answers, master side (see request.h).
#include "io/drivers/modbus/request.h"

#include <modbus/modbus.h>

#include <cstring>

namespace rtplc::modbus {
namespace {

uint8_t* put16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v >> 8);
  p[1] = static_cast<uint8_t>(v);
  return p + 2;
}

uint8_t read_function(Table t) {
  switch (t) {
    case Table::kCoil: return 1;
    case Table::kDiscreteInput: return 2;
    case Table::kHoldingRegister: return 3;
    case Table::kInputRegister: return 4;
  }
  return 3;
}

Outcome protocol_error(int code) { return Outcome{Outcome::Kind::kProtocol, code}; }

}  // namespace

Asked read_request(uint8_t unit, Table table, uint16_t start, uint16_t count) {
  Asked rq;
  rq.unit = unit;
  rq.function = read_function(table);
  rq.address = start;
  rq.count = count;
  return rq;
}

Asked write_request(uint8_t unit, const Address& a, const uint16_t* words) {
  Asked rq;
  rq.unit = unit;
  rq.address = a.address;
  if (a.table == Table::kCoil) {
    rq.function = 5;
    rq.count = 1;
    rq.words[0] = words[0] != 0 ? 1 : 0;
  } else if (width(a) == 1) {
    rq.function = 6;
    rq.count = 1;
    rq.words[0] = words[0];
  } else {
    rq.function = 16;
    rq.count = 2;
    rq.words[0] = words[0];
    rq.words[1] = words[1];
  }
  return rq;
}

size_t frame_request(const Asked& rq, uint16_t tid, uint8_t* out) {
  uint8_t* p = out + 7;  // the PDU after the MBAP header
  *p++ = rq.function;
  p = put16(p, rq.address);
  switch (rq.function) {
    case 5: p = put16(p, rq.words[0] ? 0xFF00 : 0x0000); break;
    case 6: p = put16(p, rq.words[0]); break;
    case 16:
      p = put16(p, 2);
      *p++ = 4;
      p = put16(p, rq.words[0]);
      p = put16(p, rq.words[1]);
      break;
    default: p = put16(p, rq.count); break;  // reads
  }
  const auto pdu_len = static_cast<size_t>(p - (out + 7));
  put16(out, tid);
  put16(out + 2, 0);  // protocol: Modbus
  put16(out + 4, static_cast<uint16_t>(pdu_len + 1));
  out[6] = rq.unit;
  return 7 + pdu_len;
}

Outcome check_answer(const Asked& rq, const Frame& answer, uint16_t* words) {
  const uint8_t* pdu = answer.pdu;
  const size_t n = answer.pdu_len;
  if (answer.unit != rq.unit) return protocol_error(EMBBADSLAVE);
  if (n < 1) return protocol_error(EMBBADDATA);
  if (pdu[0] == (rq.function | 0x80)) {
    if (n != 2) return protocol_error(EMBBADEXC);
    if (pdu[1] == 0 || pdu[1] > EMBXGTAR - MODBUS_ENOBASE) return protocol_error(EMBUNKEXC);
    return Outcome{Outcome::Kind::kException, pdu[1]};
  }
  if (pdu[0] != rq.function) return protocol_error(EMBBADDATA);
  switch (rq.function) {
    case 1:
    case 2: {
      const size_t bytes = (size_t{rq.count} + 7) / 8;
      if (n != 2 + bytes || pdu[1] != bytes) return protocol_error(EMBBADDATA);
      for (uint16_t i = 0; i < rq.count; ++i) words[i] = (pdu[2 + i / 8] >> (i % 8)) & 1;
      return {};
    }
    case 3:
    case 4: {
      const size_t bytes = 2 * size_t{rq.count};
      if (n != 2 + bytes || pdu[1] != bytes) return protocol_error(EMBBADDATA);
      for (uint16_t i = 0; i < rq.count; ++i) words[i] = be16(pdu + 2 + 2 * i);
      return {};
    }
    case 5:
    case 6: {
      uint8_t echo[5];
      put16(put16(echo + 1, rq.address), rq.function == 5 ? (rq.words[0] ? 0xFF00 : 0) : rq.words[0]);
      echo[0] = rq.function;
      if (n != 5 || std::memcmp(pdu, echo, 5) != 0) return protocol_error(EMBBADDATA);
      return {};
    }
    case 16:
      if (n != 5 || be16(pdu + 1) != rq.address || be16(pdu + 3) != rq.count) return protocol_error(EMBBADDATA);
      return {};
    default: return protocol_error(EMBBADDATA);
  }
}

}  // namespace rtplc::modbus
