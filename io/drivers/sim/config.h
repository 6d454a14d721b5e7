// The `sim` driver's settings (spec io-links.md, "The simulated plant"): the
// plants one driver integrates, each driven by a dao channel (a task output,
// `out/DIO/pN.dN.cN`) and measured by a dai channel (`in/DIO/pN.dN.cN`).
// Parsed by config.cpp into DriverConfig::settings.
#pragma once

#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "config/values.h"

namespace rtplc::sim {

inline constexpr const char* kDefaultPlantModel = "second-order";
inline constexpr const char* kDefaultPlantChannel = "p0.d0.c0";

struct PlantConfig {
  std::string model = kDefaultPlantModel;     // io/drivers/sim/plant.h make_plant() spec, validated
  std::string input = kDefaultPlantChannel;   // canonical "pN.dN.cN" of the dao channel
  std::string output = kDefaultPlantChannel;  // canonical "pN.dN.cN" of the dai channel
  config::ChannelAddress input_addr;
  config::ChannelAddress output_addr;
  SourcePos pos;  // the plant's entry (or the driver's, for the default plant)
  SourcePos model_pos, input_pos, output_pos;
};

struct Settings {
  std::vector<PlantConfig> plants;
};

// The settings a sim driver's parser stored (empty for a config not parsed as sim).
const Settings& settings_of(const config::DriverConfig& d);

// The dai / dao channel keys of a plant.
std::string plant_output_key(const PlantConfig& p);
std::string plant_input_key(const PlantConfig& p);

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::sim
