// The modbus-server's answers to request PDUs (see requests.h).
#include "io/drivers/modbus_server/requests.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace rtplc::modbus_server {
using modbus::ItemType;
using modbus::Table;
namespace {

size_t table_index(Table t) { return static_cast<size_t>(t); }

Table table_of(uint8_t function) {
  switch (function) {
    case 1:
    case 5:
    case 15: return Table::kCoil;
    case 2: return Table::kDiscreteInput;
    case 4: return Table::kInputRegister;
    default: return Table::kHoldingRegister;
  }
}

bool usable(Quality q) { return q == Quality::kGood || q == Quality::kForced; }

}  // namespace

bool encode_item(const ExposeItem& e, double value, uint16_t* words) {
  if (!std::isfinite(value)) return false;
  if (modbus::is_bit_table(e.item.table)) {
    words[0] = value != 0 ? 1 : 0;
    return true;
  }
  double raw = (value - e.offset) / e.scale;
  if (e.item.type != ItemType::kF32) raw = std::round(raw);
  if (!modbus::fits(e.item, raw)) return false;
  modbus::encode(e.item, raw, words);
  return true;
}

double decode_item(const ExposeItem& e, const uint16_t* words) {
  if (modbus::is_bit_table(e.item.table)) return words[0] != 0 ? 1.0 : 0.0;
  return modbus::decode(e.item, words) * e.scale + e.offset;
}

RequestHandler::RequestHandler(const ServerSettings& s, std::vector<bool> writable, Reader read, Writer write)
    : s_(s), writable_(std::move(writable)), read_(std::move(read)), write_(std::move(write)) {
  for (uint32_t i = 0; i < s_.items.size(); ++i) {
    const Address& a = s_.items[i].item;
    for (uint16_t w = 0; w < modbus::width(a); ++w) {
      cells_[table_index(a.table)].push_back({static_cast<uint16_t>(a.address + w), w, i});
    }
  }
  for (auto& t : cells_) {
    std::sort(t.begin(), t.end(), [](const Cell& x, const Cell& y) { return x.address < y.address; });
  }
}

const RequestHandler::Cell* RequestHandler::find(Table t, uint16_t address) const {
  const auto& cells = cells_[table_index(t)];
  auto it = std::lower_bound(cells.begin(), cells.end(), address,
                             [](const Cell& c, uint16_t a) { return c.address < a; });
  return it != cells.end() && it->address == address ? &*it : nullptr;
}

std::vector<uint8_t> RequestHandler::answer(const uint8_t* pdu, size_t len, Outcome& out) const {
  modbus::Request rq;
  const uint8_t function = len > 0 ? pdu[0] : 0;
  if (const uint8_t e = modbus::parse_request(pdu, len, rq); e != 0) {
    out.exception = e;
    return modbus::exception_reply(function, e);
  }
  std::vector<uint8_t> reply = rq.function <= 4 ? read(rq, out) : write(rq, pdu, out);
  if (out.exception != 0) return modbus::exception_reply(rq.function, out.exception);
  return reply;
}

std::vector<uint8_t> RequestHandler::read(const modbus::Request& rq, Outcome& out) const {
  const Table t = table_of(rq.function);
  std::vector<uint16_t> words(rq.count);
  // Each item is read once per request, so both words of a pair come from one reading.
  std::map<uint32_t, std::array<uint16_t, 2>> encoded;
  for (uint16_t i = 0; i < rq.count; ++i) {
    const Cell* c = find(t, static_cast<uint16_t>(rq.address + i));
    if (c == nullptr) {
      out.exception = modbus::kExceptionIllegalAddress;
      return {};
    }
    auto it = encoded.find(c->item);
    if (it == encoded.end()) {
      const ItemReading r = read_(c->item);
      std::array<uint16_t, 2> w{};
      if (!usable(r.quality) || !encode_item(s_.items[c->item], r.value, w.data())) {
        out.exception = modbus::kExceptionDeviceFailure;
        return {};
      }
      it = encoded.emplace(c->item, w).first;
    }
    words[i] = it->second[c->word];
  }
  if (modbus::is_bit_table(t)) {
    std::vector<uint8_t> bits(words.begin(), words.end());
    return modbus::bits_reply(rq.function, bits.data(), rq.count);
  }
  return modbus::registers_reply(rq.function, words.data(), rq.count);
}

std::vector<uint8_t> RequestHandler::write(const modbus::Request& rq, const uint8_t* pdu, Outcome& out) const {
  const Table t = table_of(rq.function);
  auto word_at = [&](uint16_t i) -> uint16_t {
    switch (rq.function) {
      case 5:
      case 6: return rq.value;
      case 15: return rq.bit_at(i) ? 1 : 0;
      default: return rq.register_at(i);
    }
  };
  // Check the whole request before anything is written.
  struct Pending {
    uint32_t item;
    uint16_t words[2];
    uint16_t seen;
  };
  std::vector<Pending> items;
  for (uint16_t i = 0; i < rq.count; ++i) {
    const Cell* c = find(t, static_cast<uint16_t>(rq.address + i));
    if (c == nullptr || !writable_[c->item]) {
      out.exception = modbus::kExceptionIllegalAddress;
      return {};
    }
    if (items.empty() || items.back().item != c->item) items.push_back({c->item, {0, 0}, 0});
    items.back().words[c->word] = word_at(i);
    ++items.back().seen;
  }
  std::vector<double> values;
  for (const Pending& p : items) {
    const ExposeItem& e = s_.items[p.item];
    const double v = decode_item(e, p.words);
    if (p.seen != modbus::width(e.item) || !std::isfinite(v)) {
      out.exception = modbus::kExceptionIllegalValue;
      return {};
    }
    values.push_back(v);
  }
  for (size_t k = 0; k < items.size(); ++k) {
    const ExposeItem& e = s_.items[items[k].item];
    auto r = write_(items[k].item, values[k]);
    if (!r) {
      out.write_refused = true;
      out.log.push_back(fmt::format("{} = {} refused: {}", e.label, values[k], r.error()));
      // The runtime says "cannot retain" when the disk failed, not the value.
      out.exception = r.error().find("cannot retain") != std::string::npos ? modbus::kExceptionDeviceFailure
                                                                            : modbus::kExceptionIllegalValue;
      return {};
    }
    ++out.written;
    out.log.push_back(*r);
  }
  return modbus::write_reply(pdu);
}

}  // namespace rtplc::modbus_server
