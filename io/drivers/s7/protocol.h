// The S7 wire format (spec: s7-client.md, "Protocol"): TPKT (RFC 1006), COTP
// (ISO 8073 class 0) and the S7 PDUs we speak — setup communication, read var and
// write var. Encoders append to a byte vector; decoders take a span, check every
// length field against the bytes really present, and return spans into the input
// (no copies), so a reply that lies about its lengths is an error, never a read past
// the end. Nothing here knows about sockets or time: the connection state machine
// (connection.h) and the fake PLC (fake_plc.h) both build on it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/result.h"

namespace rtplc::s7 {

using Bytes = std::vector<uint8_t>;
using ByteSpan = std::span<const uint8_t>;

// --- constants -------------------------------------------------------------------

// Memory areas as they appear in a request item.
enum class Area : uint8_t {
  kInputs = 0x81,    // I (E)
  kOutputs = 0x82,   // Q (A)
  kFlags = 0x83,     // M
  kDB = 0x84,        // DBn
  kCounters = 0x1C,  // C (Z)
  kTimers = 0x1D,    // T
};

// Transport size in a request item: the unit COUNT is expressed in.
enum class TransportSize : uint8_t {
  kBit = 0x01,
  kByte = 0x02,
  kChar = 0x03,
  kWord = 0x04,
  kInt = 0x05,
  kDWord = 0x06,
  kDInt = 0x07,
  kReal = 0x08,
  kCounter = 0x1C,
  kTimer = 0x1D,
};

// Transport size in a data item (reply data, write data): says whether LEN counts
// bits or bytes.
enum class DataSize : uint8_t {
  kNull = 0x00,
  kBit = 0x03,          // LEN in bits (always 1)
  kByte = 0x04,         // BYTE/WORD/DWORD, LEN in bits
  kInteger = 0x05,      // LEN in bits
  kReal = 0x07,         // LEN in bytes
  kOctetString = 0x09,  // LEN in bytes (counters, timers)
};

inline constexpr uint8_t kRosctrJob = 0x01;
inline constexpr uint8_t kRosctrAck = 0x02;
inline constexpr uint8_t kRosctrAckData = 0x03;
inline constexpr uint8_t kRosctrUserData = 0x07;

inline constexpr uint8_t kFuncSetup = 0xF0;
inline constexpr uint8_t kFuncRead = 0x04;
inline constexpr uint8_t kFuncWrite = 0x05;

inline constexpr uint8_t kItemOk = 0xFF;

inline constexpr size_t kTpktHeader = 4;
inline constexpr size_t kCotpDtHeader = 3;
inline constexpr size_t kS7JobHeader = 10;
inline constexpr size_t kS7AckHeader = 12;
inline constexpr size_t kReadItemSize = 12;
// Where the PDU reference sits in a whole frame (TPKT + COTP DT + 4 bytes of S7
// header): lets a pre-encoded request be re-sent with a new reference.
inline constexpr size_t kFramePduRefOffset = kTpktHeader + kCotpDtHeader + 4;
// Largest frame we accept: the biggest PDU any CPU negotiates is 960 (S7-1500) and
// snap7 allows 4096; anything bigger is a lie about the length.
inline constexpr size_t kMaxFrame = 8192;
// snap7 and most CPUs refuse more than 20 items in one read or write.
inline constexpr size_t kMaxItemsPerPdu = 20;

// --- TSAPs -------------------------------------------------------------------------

enum class ConnectionType : uint8_t { kPG = 1, kOP = 2, kBasic = 3 };

// The remote TSAP of an S7-300/400/1200/1500: connection type in the high byte,
// rack * 32 + slot in the low byte.
uint16_t remote_tsap(ConnectionType type, unsigned rack, unsigned slot);

// --- framing ---------------------------------------------------------------------

// Appends a TPKT + COTP Connection Request.
void encode_connection_request(Bytes& out, uint16_t local_tsap, uint16_t remote_tsap);

enum class CotpType : uint8_t {
  kConnectionRequest = 0xE0,
  kConnectionConfirm = 0xD0,
  kDisconnectRequest = 0x80,
  kDisconnectConfirm = 0xC0,
  kData = 0xF0,
  kError = 0x70,
};

struct CotpTpdu {
  CotpType type = CotpType::kData;
  bool last = true;        // DT: EOT bit
  uint16_t dst_ref = 0;    // CR/CC/DR
  uint16_t src_ref = 0;    // CR/CC/DR
  uint8_t reason = 0;      // DR: disconnect reason, ER: reject cause
  uint16_t tpdu_size = 0;  // CR/CC: bytes, 0 if the parameter was absent
  uint16_t calling_tsap = 0;
  uint16_t called_tsap = 0;
  ByteSpan payload;        // DT: user data
};

// Checks the TPKT header of `buf`: returns the frame length if a whole frame is
// present, 0 if more bytes are needed, an error if the header is impossible.
Result<size_t> tpkt_frame_length(ByteSpan buf);

// Parses one whole TPKT frame (as delimited by tpkt_frame_length).
Result<CotpTpdu> parse_frame(ByteSpan frame);

// --- S7 header -------------------------------------------------------------------

struct S7Header {
  uint8_t rosctr = 0;
  uint16_t pdu_ref = 0;
  uint8_t error_class = 0;  // ack / ack_data only
  uint8_t error_code = 0;
  ByteSpan params;
  ByteSpan data;
  uint16_t error() const { return static_cast<uint16_t>(error_class << 8 | error_code); }
};

Result<S7Header> parse_s7(ByteSpan cotp_payload);

// Wraps S7 header fields with TPKT + COTP DT and appends to `out`; returns the offset
// of the S7 header's parameter section in `out` (for encoders that patch lengths).
void encode_job_header(Bytes& out, uint16_t pdu_ref, uint16_t param_len, uint16_t data_len);
void encode_ack_header(Bytes& out, uint8_t rosctr, uint16_t pdu_ref, uint16_t param_len,
                       uint16_t data_len, uint16_t error);
// Sets the TPKT length of the frame starting at `frame_start` to the bytes after it.
void patch_tpkt_length(Bytes& out, size_t frame_start);
// Rewrites the PDU reference of a whole encoded frame.
void patch_pdu_ref(std::span<uint8_t> frame, uint16_t pdu_ref);

// --- setup communication ------------------------------------------------------

struct SetupParams {
  uint16_t amq_calling = 1;  // parallel jobs the client may have outstanding
  uint16_t amq_called = 1;
  uint16_t pdu_size = 480;
};

void encode_setup_request(Bytes& out, uint16_t pdu_ref, const SetupParams& p);
Result<SetupParams> parse_setup(const S7Header& h);  // job or ack_data

// --- read var / write var ----------------------------------------------------------

// One request item (12 bytes on the wire).
struct VarSpec {
  TransportSize ts = TransportSize::kByte;
  uint16_t count = 1;
  uint16_t db = 0;
  Area area = Area::kDB;
  uint32_t address = 0;  // bit address (byte * 8 + bit); counters/timers: the index
};

// Bytes a VarSpec transfers (what the data item carries).
size_t var_data_bytes(const VarSpec& v);

void encode_read_request(Bytes& out, uint16_t pdu_ref, std::span<const VarSpec> vars);

// A data item of a reply or of a write request; `data` points into the frame.
struct DataItem {
  uint8_t return_code = 0;
  DataSize size = DataSize::kNull;
  ByteSpan data;
};

// Data item transport size used when writing (or answering a read of) `ts`.
DataSize data_size_for(TransportSize ts);

// Encodes a write; `values[i]` must hold var_data_bytes(vars[i]) bytes.
void encode_write_request(Bytes& out, uint16_t pdu_ref, std::span<const VarSpec> vars,
                          std::span<const ByteSpan> values);

// Parses the parameters of a read/write job (what a PLC receives).
Result<std::vector<VarSpec>> parse_var_params(const S7Header& h, uint8_t function);
// Parses the data section of a read reply or write request: `count` items. Fills
// `out` (reused to avoid allocation); errors if any length runs past the data.
Result<void> parse_data_items(ByteSpan data, size_t count, bool with_return_code,
                              std::vector<DataItem>& out);

// Checks an ack_data for function `function` with `count` items: the header error,
// the function code and the item count. The message of an error is user-facing.
Result<void> check_ack(const S7Header& h, uint8_t function, size_t count);

// Decodes a read var reply into `out` (one DataItem per requested var).
Result<void> parse_read_reply(const S7Header& h, size_t count, std::vector<DataItem>& out);
// Decodes a write var reply into `codes` (one return code per written var).
Result<void> parse_write_reply(const S7Header& h, size_t count, std::vector<uint8_t>& codes);

// Encodes a read reply (for the fake PLC); items carry their own return code.
void encode_read_reply(Bytes& out, uint16_t pdu_ref, std::span<const DataItem> items);
void encode_write_reply(Bytes& out, uint16_t pdu_ref, std::span<const uint8_t> codes);
// An ack_data that carries only a header error (e.g. 0x8500).
void encode_error_reply(Bytes& out, uint16_t pdu_ref, uint16_t error);

// --- size limits of one PDU ------------------------------------------------------

// Request: 10 header + 2 + 12 per item.
inline constexpr size_t read_request_size(size_t items) { return kS7JobHeader + 2 + kReadItemSize * items; }
// Reply: 12 header + 2 + per item 4 + data + pad.
inline constexpr size_t reply_item_size(size_t bytes) { return 4 + bytes + (bytes & 1); }
inline constexpr size_t read_reply_base() { return kS7AckHeader + 2; }
// Largest single read in one PDU (the spec's "PDU - 18").
inline constexpr size_t max_read_bytes(size_t pdu) { return pdu > 18 ? pdu - 18 : 0; }

// --- messages ---------------------------------------------------------------------

// "object does not exist (0x0A)": what an item return code means.
std::string item_error_message(uint8_t return_code);
const char* item_error_name(uint8_t return_code);  // the message without its code
// The meaning of a header error class/code pair, with a hint where we know one.
std::string header_error_message(uint16_t error);
std::string area_name(Area a);

}  // namespace rtplc::s7
