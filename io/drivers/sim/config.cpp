// The `sim` driver kind of the configuration (spec io-links.md, "The simulated
// plant"): a list of plants, each driven by a dao channel and measured by a dai
// channel. The plant spec is validated by io::make_plant(), the very function
// the runtime and `rtplc sim --plant` build plants with, so a config that loads
// never fails later on its plant.
#include <string>
#include <string_view>

#include "io/drivers/sim/config.h"

#include "blocks/image.h"
#include "config/map_entries.h"
#include "config/yaml_reader.h"
#include "io/drivers/sim/plant.h"

namespace rtplc::sim {
using namespace config;
namespace {

constexpr double kMaxPlants = 64;

const KeySpec kSimKeys[] = {
    {"plants", ValueType::kList, false, 1, kMaxPlants, "plant",
     "one `second-order` plant, input and output p0.d0.c0",
     "The simulated plants this driver integrates, each between a dao and a dai channel."},
};

const KeySpec kPlantKeys[] = {
    {"model", ValueType::kPlantModel, false, 0, 0, nullptr, kDefaultPlantModel,
     "The plant, as `rtplc sim --plant` takes it."},
    {"input", ValueType::kChannel, true, 0, 0, nullptr, "",
     "The dao channel whose value drives the plant."},
    {"output", ValueType::kChannel, true, 0, 0, nullptr, "",
     "The dai channel that receives the plant's measurement."},
};

const SectionSpec kSimSection{"sim", "a sim driver", "`kind: sim`",
                              "The built-in plant simulator: how rtplc runs with no "
                              "hardware, and how the tests close real loops.",
                              kSimKeys};
const SectionSpec kPlantSection{
    "plant", "a plant", "`plants:` entries of a sim driver",
    "Each plant is integrated with RK4 at a step finer than the driver's period. One dai "
    "channel is fed by one plant; one dao channel may drive several. A model holding "
    "commas must be quoted inside `{ }`: `{model: 'fopdt:K=1,T=5', input: p0.d1.c0, "
    "output: p0.d1.c0}`.",
    kPlantKeys};

const SectionSpec* const kSimSubsections[] = {&kPlantSection};

// "second-order, tf, fopdt, tank": the first word of each entry of
// io::plant_help(), whose entries start two spaces in.
std::string model_names() {
  std::string names;
  std::string_view help = io::plant_help();
  while (!help.empty()) {
    const size_t nl = help.find('\n');
    std::string_view line = help.substr(0, nl);
    help = nl == std::string_view::npos ? std::string_view() : help.substr(nl + 1);
    if (line.size() < 3 || line[0] != ' ' || line[1] != ' ' || line[2] == ' ') continue;
    line.remove_prefix(2);
    const size_t end = line.find_first_of("[: ");
    names += (names.empty() ? "" : ", ") + std::string(line.substr(0, end));
  }
  return names;
}

// "; did you mean 'second-order'?" when a known model is a slip away.
std::string nearest_model(std::string_view kind) {
  std::string names = model_names();
  std::string_view rest = names;
  std::string best;
  size_t best_d = 3;
  while (!rest.empty()) {
    const size_t comma = rest.find(", ");
    const std::string_view name = rest.substr(0, comma);
    const size_t d = edit_distance(kind, name);
    if (d < best_d && d < kind.size()) {
      best_d = d;
      best = std::string(name);
    }
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 2);
  }
  return best.empty() ? std::string() : "; did you mean '" + best + "'?";
}

void parse_plant(YamlReader& r, const YAML::Node& node, SourcePos where,
                 std::vector<PlantConfig>& out) {
  PlantConfig pc;
  pc.pos = YamlReader::pos(node).line ? YamlReader::pos(node) : where;
  pc.model_pos = pc.input_pos = pc.output_pos = pc.pos;
  Fields f = r.fields(node, pc.pos, kPlantSection.noun, {kPlantSection.keys});
  if (!f.is_map()) return;
  bool ok = true;
  if (const Field* m = f.get("model")) {
    pc.model_pos = m->pos;
    if (auto s = r.text(*m)) {
      auto plant = io::make_plant(*s);
      if (plant.ok() && !(*plant)->port_inputs().empty()) {
        // A plant with several named signals (the measuring tank) is wired by
        // label in `rtplc sim`; this driver feeds one dao into one dai.
        r.error(*m, "plant model '" + *s + "' has several inputs and outputs: use it with `rtplc sim`; "
                    "a sim driver's plant is driven by one dao and measured by one dai");
        ok = false;
      } else if (plant.ok()) {
        pc.model = *s;
      } else {
        // make_plant's message may go on with its multi-line help; a
        // diagnostic is one line, so the help becomes the list of model names.
        const std::string& e = plant.error();
        std::string msg = e.substr(0, e.find('\n'));
        if (msg.size() != e.size() && !msg.empty() && msg.back() == ':') {
          msg.back() = ' ';
          msg += model_names();
          msg += nearest_model(s->substr(0, s->find(':')));
        }
        r.error(*m, "bad plant model: " + msg);
        ok = false;
      }
    } else {
      ok = false;
    }
  }
  ok &= parse_channel_field(r, f, "input", true, pc.input_addr, pc.input, &pc.input_pos);
  ok &= parse_channel_field(r, f, "output", true, pc.output_addr, pc.output, &pc.output_pos);
  if (ok) out.push_back(std::move(pc));
}

void parse_sim(YamlReader& r, const Fields& f, DriverConfig& out) {
  Settings s;
  const Field* plants = f.get("plants");
  if (!plants) {
    // The documented default: the seed's plant closing the loop on p0.d0.c0.
    PlantConfig pc;
    pc.input_addr = pc.output_addr = *parse_channel(kDefaultPlantChannel);
    pc.pos = pc.model_pos = pc.input_pos = pc.output_pos = out.pos;
    s.plants.push_back(std::move(pc));
  } else if (auto items = r.list(*plants)) {
    for (const YAML::Node& item : *items) parse_plant(r, item, plants->pos, s.plants);
  }
  out.settings = std::move(s);
}

// Each plant provides its dai channel (region index = plant index) and
// consumes its dao channel.
DriverClaims sim_claims(const DriverConfig& d) {
  DriverClaims c;
  for (const PlantConfig& p : settings_of(d).plants) {
    c.provides.push_back({plant_output_key(p), d.name + "." + p.output, p.output_pos});
    c.consumes.push_back({plant_input_key(p), d.name + "." + p.input, p.input_pos});
  }
  return c;
}

// The plant list comes from io/plant.h's own help, so a model added there
// shows up here when docs/config.md is regenerated.
std::string sim_doc() {
  return std::string("Plant models (the same text as `rtplc sim --help`):\n\n```\n") +
         io::plant_help() + "```\n";
}

}  // namespace

const Settings& settings_of(const DriverConfig& d) { return settings_as<Settings>(d); }

std::string plant_output_key(const PlantConfig& p) {
  return channel_key(BindingDir::kInput, IoGroup::kDio, 0, p.output_addr.p, p.output_addr.d,
                     p.output_addr.c);
}

std::string plant_input_key(const PlantConfig& p) {
  return channel_key(BindingDir::kOutput, IoGroup::kDio, 0, p.input_addr.p, p.input_addr.d,
                     p.input_addr.c);
}

const DriverKind kConfigKind{
    "sim",        "simulated plants on dao/dai channels (no hardware needed)",
    &kSimSection, kSimSubsections,
    &parse_sim,   &sim_claims,
    &sim_doc,
};

}  // namespace rtplc::sim
