// libFuzzer target (the `fuzz` preset): any bytes as an NCMD, a DCMD and a
// STATE to an edge node with one writable set-point. It must never crash,
// and a write may only ever be a finite number to the writable set-point.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "io/drivers/sparkplug/edge_node.h"

using namespace rtplc;
using namespace rtplc::sparkplug;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static SparkplugSettings s = [] {
    SparkplugSettings x;
    x.group = "G";
    x.node = "N";
    x.primary_host = "H";
    x.writable = {"Setpoint"};
    x.aliases = true;
    return x;
  }();
  EdgeNode node(
      s, [](const std::string&, std::string, int, bool) { return true; },
      [](const std::string& label, double v) -> Result<std::string> {
        if (label != "Setpoint" || !std::isfinite(v)) std::abort();
        return std::string("ok");
      },
      [](uint32_t c) { return Sample{static_cast<double>(c), Quality::kGood, false, 1}; }, [](bool, const std::string&) {});
  DeviceDef d;
  d.name = "loop";
  d.metrics = {MetricDef{"ProcVal", 0, false, false, 0}, MetricDef{"Setpoint", 1, false, true, 0}};
  node.set_devices({d}, 0);
  node.session_up(0, 0);
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  node.on_message("spBv1.0/STATE/H", bytes, false, 1);
  node.on_message("spBv1.0/G/NCMD/N", bytes, false, 2);
  node.on_message("spBv1.0/G/DCMD/N/loop", bytes, false, 3);
  node.tick(4);
  return 0;
}
