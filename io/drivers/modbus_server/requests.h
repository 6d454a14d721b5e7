// The modbus-server's answers (issue 9, item 2): one request PDU in, one reply
// PDU out, over the exposed items of a ServerSettings. Sans I/O: the values
// come from a reader and the writes go to a writer the caller gives, so the
// unit tests exercise every rule without a socket or a runtime.
//
// Reads (FC 1 coils, 2 discrete inputs, 3 holding, 4 input registers):
//   every address asked for must be exposed in that table, else exception 2;
//   a channel whose quality is neither good nor forced, or whose value does not
//   fit its item after scaling (70000 as a u16, NaN), fails the whole request
//   with exception 4: SCADA never gets a number we cannot vouch for.
// Writes (FC 5, 15 coils; 6, 16 holding registers):
//   every address must belong to a writable item (a set-point exposed in hr or
//   coil), else exception 2 and nothing is written; a request that covers only
//   part of a two-register item, or whose value is not finite after scaling,
//   gets exception 3 and nothing is written; then each item goes to the writer
//   in address order. A value the writer refuses (the runtime's own checks)
//   ends the request with exception 3 (4 when the value could not be retained);
//   items before it in the same request stay set.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "common/quality.h"
#include "common/result.h"
#include "io/drivers/modbus/pdu.h"
#include "io/drivers/modbus_server/config.h"

namespace rtplc::modbus_server {

struct ItemReading {
  double value = 0;
  Quality quality = Quality::kBad;
};

// What answering one request did, for the counters and the log.
struct Outcome {
  uint8_t exception = 0;     // 0: a normal reply
  uint32_t written = 0;      // set-points changed
  bool write_refused = false;
  std::vector<std::string> log;  // one line per set-point changed or refused
};

class RequestHandler {
 public:
  using Reader = std::function<ItemReading(uint32_t item)>;
  // Sets item's channel to value; the text says what changed, the error why not.
  using Writer = std::function<Result<std::string>(uint32_t item, double value)>;

  // writable[i]: whether item i may be written (its channel is a set-point and
  // its table is hr or coil).
  RequestHandler(const ServerSettings& s, std::vector<bool> writable, Reader read, Writer write);

  std::vector<uint8_t> answer(const uint8_t* pdu, size_t len, Outcome& out) const;

 private:
  struct Cell {
    uint16_t address;
    uint16_t word;  // which register of its item
    uint32_t item;
  };
  const Cell* find(modbus::Table t, uint16_t address) const;
  std::vector<uint8_t> read(const modbus::Request& rq, Outcome& out) const;
  std::vector<uint8_t> write(const modbus::Request& rq, const uint8_t* pdu, Outcome& out) const;

  const ServerSettings& s_;
  std::vector<bool> writable_;
  Reader read_;
  Writer write_;
  std::vector<Cell> cells_[4];  // per table, sorted by address
};

// The register words of an exposed item for an engineering value: false when
// the value does not fit the item after scaling (not finite, out of range).
bool encode_item(const ExposeItem& e, double value, uint16_t* words);
// The engineering value of an item's words as written by a client.
double decode_item(const ExposeItem& e, const uint16_t* words);

}  // namespace rtplc::modbus_server
