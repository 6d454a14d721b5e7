// The `can` driver kind's settings (issue "CAN/GPIO", item 1; docs/can.md):
// one CAN interface and the frames exchanged on it with the drives (EPC):
//   receive   frames whose signals feed `tra`/`trd` channels
//             (`in/EPC/pN.dN.cN`), each with its own timeout;
//   transmit  frames built from `twa`/`twd` outputs (`out/EPC/pN.dN.cN`),
//             each sent at its own period and, if asked, when a value changes.
// Parsed by config.cpp; kept in DriverConfig::settings as a CanSettings.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "config/values.h"
#include "fieldbus/link_plan.h"
#include "io/drivers/can/codec.h"

namespace rtplc::can {

using config::ChannelAddress;

struct SignalMap {
  ChannelAddress addr;  // the block's p, d, c
  std::string channel;  // "pN.dN.cN"
  SignalLayout layout;
  SourcePos pos, channel_pos;
};

struct FrameMap {
  uint32_t id = 0;
  bool extended = false;
  uint8_t length = 8;       // transmit: the frame's data length; receive: the least accepted
  double period_s = 0.1;    // transmit
  bool on_change = true;    // transmit: also sent as soon as a value changed
  double timeout_s = 0.5;   // receive: no frame for this long -> its channels bad
  std::vector<SignalMap> signals;
  SourcePos pos, id_pos;
  // With the driver's plan (transmit only): the loop whose windows the frame
  // is sent in, or urgent (sent on change, first in its T_1 frame).
  enum class Class : uint8_t { kUnplanned, kPeriodic, kUrgent };
  Class tx_class = Class::kUnplanned;
  std::string loop;
};

// A non-RT transfer of a link that runs on a plan: a file's bytes, 8 to a
// frame on one id, cut into fragments of at most L_n of wire time.
struct BulkTransfer {
  uint32_t id = 0;
  bool extended = false;
  std::string file;     // resolved against the config's folder
  double every_s = 0;   // 0: once, at start
  SourcePos pos, id_pos;
};

struct CanSettings {
  std::string interface;  // can0, vcan0
  bool error_frames = true;
  std::vector<FrameMap> receive;
  std::vector<FrameMap> transmit;
  // The fieldbus plan the link runs on (docs/fieldbus.md, "Running a link on
  // a plan"); null: frames go out as they are due, unplanned.
  std::shared_ptr<const fieldbus::LinkPlan> plan;
  std::vector<BulkTransfer> bulk;
};

const CanSettings& settings_of(const config::DriverConfig& d);

// "0x181", "385", "0x18FF50E5": a CAN identifier; nullopt when not a number.
std::optional<uint32_t> parse_id(const std::string& text);

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::can
