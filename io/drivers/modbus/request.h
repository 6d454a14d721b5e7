// Modbus TCP as a master sees it (Modbus Application Protocol v1.1b3,
// "Messaging on TCP/IP" v1.0b): the request frames of the reads and writes the
// driver makes, and the answer checked against the request it answers. Pure
// functions over bytes, no I/O and no allocation, so the event loop
// (tcp_master.h) calls them per request and the fuzzer drives them directly.
//   reads   FC 1 coils, 2 discrete inputs, 3 holding, 4 input registers
//   writes  FC 5 one coil, 6 one register, 16 a register pair (32-bit items)
// An answer is one MBAP frame (pdu.h's next_frame finds it in the stream); its
// transaction id is the caller's to match (a late answer to an attempt that
// timed out is dropped there), the rest is checked here.
#pragma once

#include <cstddef>
#include <cstdint>

#include "io/drivers/modbus/address.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/pdu.h"

namespace rtplc::modbus {

// What was asked: enough to check its answer.
struct Asked {
  uint8_t unit = 0;
  uint8_t function = 0;
  uint16_t address = 0;
  uint16_t count = 0;     // reads: bits or registers; FC 16: 2
  uint16_t words[2] = {}; // writes: what was written (FC 5: 0 or 1)
};

// The largest request frame: MBAP (7) + FC 16 with two registers (10).
inline constexpr size_t kMaxRequestFrame = 17;

Asked read_request(uint8_t unit, Table table, uint16_t start, uint16_t count);
// `a` must be writable (a coil or a holding register; the config refuses others).
Asked write_request(uint8_t unit, const Address& a, const uint16_t* words);

// The frame of `rq` with transaction id `tid` into out[0..kMaxRequestFrame);
// returns its length.
size_t frame_request(const Asked& rq, uint16_t tid, uint8_t* out);

// Checks `answer` (a whole MBAP frame, transaction id already matched) against
// `rq`: kOk (reads: `words` filled, a bit as 0/1 per word), kException with the
// slave's code, or kProtocol (another unit or function, a byte count or echo
// that does not match).
Outcome check_answer(const Asked& rq, const Frame& answer, uint16_t* words);

}  // namespace rtplc::modbus
