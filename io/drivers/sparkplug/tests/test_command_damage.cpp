// The command path under random damage: valid commands with bytes flipped,
// cut short, lengthened and shuffled, fed to the edge node as NCMD and DCMD.
// Nothing may crash, and only a command that still decodes as a well-typed
// write of a writable set-point may write (never anything else, never a value
// out of nowhere: each write is one a mutated command really carries).
// A deterministic random walk, the same on every run; the libFuzzer target
// (fuzz_sparkplug, the `fuzz` preset) explores further.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "io/drivers/sparkplug/edge_node.h"

namespace rtplc::sparkplug {
namespace {

std::string seed_command(const std::string& name, uint32_t type, double v) {
  Payload p;
  p.set_timestamp(123);
  Metric* m = p.add_metrics();
  m->set_name(name);
  m->set_datatype(type);
  if (type == 11) m->set_boolean_value(v != 0);
  else if (type == 10) m->set_double_value(v);
  else m->set_int_value(static_cast<uint32_t>(static_cast<int32_t>(v)));
  return p.SerializeAsString();
}

TEST(SparkplugCommandDamage, damaged_commands_never_crash_and_never_write_what_they_do_not_say) {
  SparkplugSettings s;
  s.group = "G";
  s.node = "N";
  s.writable = {"Setpoint"};
  std::vector<std::pair<std::string, double>> writes;
  uint64_t published = 0;
  EdgeNode node(
      s, [&](const std::string&, std::string, int, bool) { return ++published, true; },
      [&](const std::string& label, double v) -> Result<std::string> {
        writes.emplace_back(label, v);
        return std::string("ok");
      },
      [](uint32_t c) { return Sample{static_cast<double>(c), Quality::kGood, false, 1}; }, [](bool, const std::string&) {});
  DeviceDef d;
  d.name = "loop";
  d.metrics = {MetricDef{"ProcVal", 0, false, false, 0}, MetricDef{"Setpoint", 1, false, true, 0}};
  node.set_devices({d}, 0);
  node.session_up(0, 0);

  const std::vector<std::string> seeds = {seed_command("Setpoint", 10, 42), seed_command("ProcVal", 10, 1),
                                          seed_command("Setpoint", 3, -7), seed_command("Node Control/Rebirth", 11, 1),
                                          seed_command("Setpoint", 11, 1)};
  std::mt19937_64 rng(20261204);
  uint64_t writes_expected = 0;
  for (int i = 0; i < 200000; ++i) {
    std::string b = seeds[rng() % seeds.size()];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !b.empty(); ++e) {
      switch (rng() % 5) {
        case 0: b[rng() % b.size()] = static_cast<char>(rng()); break;
        case 1: b.resize(rng() % b.size()); break;
        case 2: b.insert(rng() % (b.size() + 1), 1, static_cast<char>(rng())); break;
        case 3: b += seeds[rng() % seeds.size()]; break;
        default: std::swap(b[rng() % b.size()], b[rng() % b.size()]); break;
      }
    }
    // What an independent reading of the bytes says this command asks.
    Payload p;
    uint64_t would = 0;
    if (p.ParseFromString(b) && p.metrics_size() > 0 && p.metrics_size() <= 4096) {
      for (const Metric& m : p.metrics()) {
        double v = 0;
        std::string why;
        if (m.name() == "Setpoint" && metric_number(m, v, why)) ++would;
      }
    }
    const size_t before = writes.size();
    const bool as_dcmd = rng() % 4 != 0;
    node.on_message(as_dcmd ? "spBv1.0/G/DCMD/N/loop" : "spBv1.0/G/NCMD/N", b, false, 1);
    if (as_dcmd) writes_expected += would;
    for (size_t w = before; w < writes.size(); ++w) {
      ASSERT_EQ(writes[w].first, "Setpoint");
      ASSERT_TRUE(std::isfinite(writes[w].second));
    }
    if (!as_dcmd) {
      ASSERT_EQ(writes.size(), before) << "an NCMD never writes a set-point";
    }
    if (i % 1000 == 0) node.tick(static_cast<uint64_t>(i));
  }
  EXPECT_EQ(writes.size(), writes_expected);
  EXPECT_GT(writes.size(), 0u) << "some damaged commands are still good writes";
  EXPECT_GT(node.counters().bad_commands.load(), 1000u);
}

}  // namespace
}  // namespace rtplc::sparkplug
