// The edge node's state machine, message by message, without a broker: what
// it publishes at a session's start, on changes within and beyond deadbands,
// on commands good and bad, while nobody listens and after, and as devices
// come, change and go.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "io/drivers/sparkplug/edge_node.h"

namespace rtplc::sparkplug {
namespace {

struct Sent {
  std::string topic;
  Payload p;
  int qos = 0;
};

class EdgeNodeTest : public ::testing::Test {
 protected:
  EdgeNodeTest() {
    s.group = "G";
    s.node = "N";
    s.writable = {"Setpoint"};
    values[0] = Sample{1.0, Quality::kGood, false, 1000};
    values[1] = Sample{50.0, Quality::kGood, false, 1000};
    values[2] = Sample{0.0, Quality::kGood, false, 1000};
  }

  void make() {
    node = std::make_unique<EdgeNode>(
        s,
        [this](const std::string& topic, std::string payload, int qos, bool) {
          if (!up) return false;
          Sent m{topic, {}, qos};
          EXPECT_TRUE(m.p.ParseFromString(payload)) << topic;
          sent.push_back(std::move(m));
          return true;
        },
        [this](const std::string& label, double v) -> Result<std::string> {
          if (v > 100) return make_error("outside [0, 100]");
          writes.emplace_back(label, v);
          values[1].value = v;
          return std::string("ok");
        },
        [this](uint32_t c) { return values[c]; }, [this](bool warning, const std::string& line) {
          logs.push_back((warning ? "W " : "I ") + line);
        });
    node->set_devices({device("loop")}, 1000);
  }

  DeviceDef device(const std::string& name) {
    DeviceDef d;
    d.name = name;
    d.metrics = {MetricDef{"ProcVal", 0, false, false, 0.5}, MetricDef{"Setpoint", 1, false, true, 0},
                 MetricDef{"Run", 2, true, false, 0}};
    return d;
  }

  std::vector<Sent> take() {
    std::vector<Sent> out;
    out.swap(sent);
    return out;
  }

  std::string cmd(const std::string& name, double v, uint32_t type = 10) {
    Payload p;
    Metric* m = p.add_metrics();
    m->set_name(name);
    m->set_datatype(type);
    if (type == 11) m->set_boolean_value(v != 0);
    else m->set_double_value(v);
    return p.SerializeAsString();
  }

  SparkplugSettings s;
  std::map<uint32_t, Sample> values;
  std::vector<Sent> sent;
  std::vector<std::pair<std::string, double>> writes;
  std::vector<std::string> logs;
  bool up = true;
  std::unique_ptr<EdgeNode> node;
};

const Metric* find(const Payload& p, const std::string& name) {
  for (const Metric& m : p.metrics()) {
    if (m.name() == name) return &m;
  }
  return nullptr;
}

int32_t quality_of(const Metric& m) {
  const auto& ps = m.properties();
  for (int i = 0; i < ps.keys_size(); ++i) {
    if (ps.keys(i) == "Quality") return static_cast<int32_t>(ps.values(i).int_value());
  }
  return 0x7fffffff;
}

TEST_F(EdgeNodeTest, a_session_begins_with_nbirth_seq0_bdseq_then_a_dbirth_per_device) {
  make();
  node->session_up(7, 2000);
  const auto out = take();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/NBIRTH/N");
  EXPECT_EQ(out[0].p.seq(), 0u);
  const Metric* bd = find(out[0].p, "bdSeq");
  ASSERT_NE(bd, nullptr);
  EXPECT_EQ(bd->datatype(), 4u);  // Int64
  EXPECT_EQ(bd->long_value(), 7u);
  ASSERT_NE(find(out[0].p, "Node Control/Rebirth"), nullptr);
  EXPECT_EQ(out[1].topic, "spBv1.0/G/DBIRTH/N/loop");
  EXPECT_EQ(out[1].p.seq(), 1u);
  const Metric* pv = find(out[1].p, "ProcVal");
  ASSERT_NE(pv, nullptr);
  EXPECT_EQ(pv->datatype(), 10u);  // Double
  EXPECT_EQ(pv->double_value(), 1.0);
  EXPECT_EQ(pv->timestamp(), 1000u);
  EXPECT_EQ(quality_of(*pv), 192);
  EXPECT_EQ(find(out[1].p, "Run")->datatype(), 11u);  // Boolean
  EXPECT_EQ(node->subscriptions(), (std::vector<std::string>{"spBv1.0/G/NCMD/N", "spBv1.0/G/DCMD/N/+"}));
}

TEST_F(EdgeNodeTest, the_will_is_an_ndeath_with_the_sessions_bdseq_and_no_seq) {
  make();
  Payload p;
  ASSERT_TRUE(p.ParseFromString(node->death_payload(42, 5)));
  EXPECT_FALSE(p.has_seq());
  ASSERT_NE(find(p, "bdSeq"), nullptr);
  EXPECT_EQ(find(p, "bdSeq")->long_value(), 42u);
}

TEST_F(EdgeNodeTest, data_goes_by_exception_beyond_the_deadband_and_on_every_quality_change) {
  make();
  node->session_up(0, 0);
  take();
  node->tick(1);
  EXPECT_TRUE(take().empty()) << "nothing changed";
  values[0].value = 1.3;  // within the 0.5 deadband
  node->tick(2);
  EXPECT_TRUE(take().empty());
  values[0].value = 1.6;
  node->tick(3);
  auto out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/DDATA/N/loop");
  EXPECT_EQ(out[0].p.seq(), 2u);
  ASSERT_EQ(out[0].p.metrics_size(), 1);
  EXPECT_EQ(out[0].p.metrics(0).name(), "ProcVal");
  values[0].value = 1.7;  // within the deadband, but no longer good
  values[0].quality = Quality::kStale;
  node->tick(4);
  out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(quality_of(out[0].p.metrics(0)), kQualityBadStale);
  values[0].quality = Quality::kBad;
  node->tick(5);
  out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(quality_of(out[0].p.metrics(0)), kQualityBad);
  EXPECT_EQ(static_cast<uint32_t>(out[0].p.metrics(0).properties().values(0).int_value()), 0x80000200u)
      << "a negative Int32 travels as its two's-complement bits";
}

TEST_F(EdgeNodeTest, a_forced_value_says_so) {
  make();
  node->session_up(0, 0);
  take();
  values[2] = Sample{1.0, Quality::kForced, true, 5};
  node->tick(5);
  auto out = take();
  ASSERT_EQ(out.size(), 1u);
  const Metric& m = out[0].p.metrics(0);
  EXPECT_EQ(m.name(), "Run");
  EXPECT_TRUE(m.boolean_value());
  ASSERT_EQ(m.properties().keys_size(), 2);
  EXPECT_EQ(m.properties().keys(1), "Forced");
  EXPECT_TRUE(m.properties().values(1).boolean_value());
}

TEST_F(EdgeNodeTest, seq_wraps_from_255_to_0) {
  make();
  node->session_up(0, 0);
  take();
  uint64_t last = 1;
  for (int i = 0; i < 300; ++i) {
    values[1].value += 1;
    node->tick(static_cast<uint64_t>(i));
    auto out = take();
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].p.seq(), (last + 1) % 256);
    last = out[0].p.seq();
  }
}

TEST_F(EdgeNodeTest, a_rebirth_burst_is_one_rebirth_with_the_same_bdseq) {
  make();
  node->session_up(3, 0);
  take();
  for (int i = 0; i < 20; ++i) node->on_message("spBv1.0/G/NCMD/N", cmd("Node Control/Rebirth", 1, 11), false, 1);
  EXPECT_TRUE(take().empty()) << "done at the next tick";
  node->tick(2);
  auto out = take();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/NBIRTH/N");
  EXPECT_EQ(out[0].p.seq(), 0u);
  EXPECT_EQ(find(out[0].p, "bdSeq")->long_value(), 3u);
  EXPECT_EQ(out[1].p.seq(), 1u);
  node->tick(3);
  EXPECT_TRUE(take().empty());
}

TEST_F(EdgeNodeTest, dcmd_writes_only_writable_set_points_and_refuses_the_rest) {
  make();
  node->session_up(0, 0);
  take();
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("ProcVal", 5), false, 1);        // an input
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("Nothing", 5), false, 1);        // no such metric
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("Setpoint", 150), false, 1);     // the API refuses
  node->on_message("spBv1.0/G/DCMD/N/other", cmd("Setpoint", 5), false, 1);      // no such device
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("Setpoint", 60), true, 1);       // retained
  node->on_message("spBv1.0/G/DCMD/N/loop", "\x0a\xff\xff garbage", false, 1);   // not protobuf
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("Setpoint", 1, 12), false, 1);   // a String
  EXPECT_TRUE(writes.empty());
  EXPECT_EQ(node->counters().writes_refused.load(), 4u);
  EXPECT_EQ(node->counters().bad_commands.load(), 3u);
  EXPECT_EQ(logs.size(), 7u);
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("Setpoint", 42), false, 1);
  ASSERT_EQ(writes.size(), 1u);
  EXPECT_EQ(writes[0], (std::pair<std::string, double>{"Setpoint", 42}));
  node->tick(2);
  auto out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(find(out[0].p, "Setpoint")->double_value(), 42);
}

TEST_F(EdgeNodeTest, an_oversized_command_is_refused_unread) {
  s.max_command_bytes = 64;
  make();
  node->session_up(0, 0);
  node->on_message("spBv1.0/G/DCMD/N/loop", cmd("Setpoint", 42) + std::string(100, '\0'), false, 1);
  EXPECT_TRUE(writes.empty());
  EXPECT_NE(logs.back().find("larger than the 64 taken"), std::string::npos) << logs.back();
}

TEST_F(EdgeNodeTest, while_offline_changes_are_stored_then_replayed_after_the_births_as_historical) {
  s.replay_rate = 1000;
  make();
  node->session_up(0, 0);
  node->tick(1);
  up = false;
  node->session_down();
  take();
  for (int i = 0; i < 5; ++i) {
    values[1].value = 10 + i;
    node->tick(static_cast<uint64_t>(100 + i));
  }
  EXPECT_EQ(node->counters().stored.load(), 5u);
  up = true;
  node->session_up(1, 1000);
  node->tick(1100);
  auto out = take();
  ASSERT_GE(out.size(), 3u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/NBIRTH/N");
  EXPECT_EQ(out[1].topic, "spBv1.0/G/DBIRTH/N/loop");
  EXPECT_EQ(out[2].topic, "spBv1.0/G/DDATA/N/loop");
  ASSERT_EQ(out[2].p.metrics_size(), 5);
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(out[2].p.metrics(i).is_historical());
    EXPECT_EQ(out[2].p.metrics(i).double_value(), 10 + i) << "in order";
  }
  EXPECT_EQ(node->counters().stored.load(), 0u);
  EXPECT_EQ(node->counters().replayed.load(), 5u);
}

TEST_F(EdgeNodeTest, a_full_store_drops_the_oldest_and_counts) {
  s.store_and_forward = 3;
  make();
  node->session_up(0, 0);
  node->tick(1);
  up = false;
  node->session_down();
  for (int i = 0; i < 10; ++i) {
    values[1].value = 10 + i;
    node->tick(static_cast<uint64_t>(100 + i));
  }
  EXPECT_EQ(node->counters().stored.load(), 3u);
  EXPECT_EQ(node->counters().dropped.load(), 7u);
}

TEST_F(EdgeNodeTest, the_replay_keeps_its_rate_and_live_changes_wait_behind_it) {
  s.replay_rate = 100;  // per second
  make();
  node->session_up(0, 0);
  node->tick(1);
  up = false;
  node->session_down();
  for (int i = 0; i < 50; ++i) {
    values[1].value = 10 + i;
    node->tick(static_cast<uint64_t>(100 + i));
  }
  up = true;
  node->session_up(1, 10000);
  take();
  node->tick(10100);  // 100 ms: about 10
  auto out = take();
  int replayed = 0;
  for (const Sent& m : out) replayed += m.p.metrics_size();
  EXPECT_GE(replayed, 9);
  EXPECT_LE(replayed, 11);
  values[0].value = 99;  // a live change now goes behind the replay, in order
  node->tick(10200);
  out = take();
  for (const Sent& m : out) EXPECT_EQ(find(m.p, "ProcVal"), nullptr);
  node->tick(20000);
  out = take();
  ASSERT_FALSE(out.empty());
  const Metric* live = find(out.back().p, "ProcVal");
  ASSERT_NE(live, nullptr);
  EXPECT_FALSE(live->is_historical());
}

TEST_F(EdgeNodeTest, the_primary_host_gates_the_births_and_its_offline_ends_the_session) {
  s.primary_host = "scada";
  make();
  node->session_up(0, 0);
  EXPECT_TRUE(take().empty());
  EXPECT_EQ(node->phase(), EdgeNode::Phase::kWaiting);
  node->on_message("spBv1.0/STATE/scada", R"({"online": true, "timestamp": 100})", true, 1);
  auto out = take();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/NBIRTH/N");
  node->on_message("spBv1.0/STATE/scada", R"({"online": false, "timestamp": 50})", false, 2);  // stale
  EXPECT_FALSE(node->wants_reconnect());
  node->on_message("spBv1.0/STATE/scada", "{bad", false, 2);
  EXPECT_FALSE(node->wants_reconnect());
  node->on_message("spBv1.0/STATE/scada", R"({"online": false, "timestamp": 200})", false, 3);
  EXPECT_TRUE(node->wants_reconnect());
  node->shutdown(4);
  out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/NDEATH/N");
  EXPECT_FALSE(node->wants_reconnect()) << "the next session starts clean";
}

TEST_F(EdgeNodeTest, a_changed_device_dies_and_is_born_again_and_a_stopped_one_dies) {
  make();
  node->session_up(0, 0);
  take();
  DeviceDef d = device("loop");
  d.metrics.pop_back();  // a swap without Run
  node->set_devices({d}, 5);
  auto out = take();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/DDEATH/N/loop");
  EXPECT_EQ(out[1].topic, "spBv1.0/G/DBIRTH/N/loop");
  EXPECT_EQ(out[1].p.metrics_size(), 2);
  d.running = false;
  node->set_devices({d}, 6);
  out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].topic, "spBv1.0/G/DDEATH/N/loop");
  EXPECT_EQ(out[0].p.seq(), 4u) << "one counter: NBIRTH 0, DBIRTH 1, DDEATH 2, DBIRTH 3";
}

TEST_F(EdgeNodeTest, aliases_name_metrics_in_births_only) {
  s.aliases = true;
  make();
  node->session_up(0, 0);
  auto out = take();
  const Metric* pv = find(out[1].p, "ProcVal");
  ASSERT_NE(pv, nullptr);
  ASSERT_TRUE(pv->has_alias());
  const uint64_t alias = pv->alias();  // `out` is replaced below
  values[0].value = 9;
  node->tick(1);
  out = take();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_FALSE(out[0].p.metrics(0).has_name());
  EXPECT_EQ(out[0].p.metrics(0).alias(), alias);
}

TEST(SparkplugPayload, signed_and_unsigned_types_decode_by_their_declared_type) {
  Metric m;
  double v = 0;
  std::string why;
  m.set_datatype(3);  // Int32
  m.set_int_value(0xFFFFFFFFu);
  ASSERT_TRUE(metric_number(m, v, why)) << why;
  EXPECT_EQ(v, -1);
  m.set_datatype(7);  // UInt32
  ASSERT_TRUE(metric_number(m, v, why));
  EXPECT_EQ(v, 4294967295.0);
  m.set_datatype(4);  // Int64
  m.set_long_value(~uint64_t{0});
  ASSERT_TRUE(metric_number(m, v, why));
  EXPECT_EQ(v, -1);
  m.set_datatype(1);  // Int8 out of range
  m.set_int_value(200);
  EXPECT_FALSE(metric_number(m, v, why));
  m.set_datatype(10);  // Double without double_value
  m.set_int_value(1);
  EXPECT_FALSE(metric_number(m, v, why));
  EXPECT_NE(why.find("double_value"), std::string::npos);
  m.set_double_value(std::numeric_limits<double>::quiet_NaN());
  EXPECT_FALSE(metric_number(m, v, why));
}

}  // namespace
}  // namespace rtplc::sparkplug
