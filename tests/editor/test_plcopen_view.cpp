// The editor's read-only PLCopen view against the example project: every POU
// listed with its language, ST bodies as text, FBD elements with their
// connections; positions kept when the project gives them, and a flow depth
// (sources left of what they feed) when it puts everything at 0,0; a project
// the reader refuses is refused with its message.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "editor/plcopen_view.h"

namespace rtplc::editor {
namespace {

using nlohmann::json;

std::string tank_xml() {
  std::ifstream f(std::string(RTPLC_SOURCE_DIR) + "/examples/plcopen_tank.xml");
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

const json* pou(const json& v, const std::string& name) {
  for (const json& p : v["pous"]) {
    if (p["name"] == name) return &p;
  }
  return nullptr;
}

TEST(PlcopenView, lists_every_pou_and_connects_the_fbd_elements_in_flow_order) {
  auto v = plcopen_view(tank_xml());
  ASSERT_TRUE(v) << v.error();
  const json* hys = pou(*v, "Hysteresis");
  ASSERT_NE(hys, nullptr);
  EXPECT_EQ((*hys)["language"], "ST");
  EXPECT_FALSE((*hys)["source"].get<std::string>().empty());
  const json* main = pou(*v, "main");
  ASSERT_NE(main, nullptr);
  EXPECT_EQ((*main)["language"], "FBD");
  EXPECT_FALSE((*main)["positioned"].get<bool>());  // every element at 0,0 in this project
  std::map<std::string, const json*> by_id;
  for (const json& e : (*main)["elements"]) by_id[e["id"].get<std::string>()] = &e;
  ASSERT_TRUE(by_id.count("2") && by_id.count("3") && by_id.count("5"));
  EXPECT_EQ((*by_id["2"])["type"], "Hysteresis");
  EXPECT_EQ((*by_id["2"])["instance"], "hys");
  // TON t1 reads hys.Q: one deeper than hys; the outVariable after t1 deeper still.
  bool reads_hys = false;
  for (const json& in : (*by_id["3"])["inputs"]) {
    if (in["from"] == "2" && in["from_pin"] == "Q") reads_hys = true;
  }
  EXPECT_TRUE(reads_hys);
  EXPECT_GT((*by_id["3"])["depth"].get<int>(), (*by_id["2"])["depth"].get<int>());
  EXPECT_GT((*by_id["5"])["depth"].get<int>(), (*by_id["3"])["depth"].get<int>());
  // AND's IN2 is negated in the project, and says so.
  for (const json& in : (*by_id["10"])["inputs"]) {
    if (in["pin"] == "IN2") {
      EXPECT_TRUE(in["negated"].get<bool>());
    }
  }
}

TEST(PlcopenView, keeps_the_projects_own_positions) {
  std::string xml = tank_xml();
  int k = 0;
  std::string out;
  std::regex zero(R"(<position x="0" y="0"/>)");
  auto begin = std::sregex_iterator(xml.begin(), xml.end(), zero);
  size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    out += xml.substr(last, static_cast<size_t>(it->position()) - last);
    ++k;
    out += "<position x=\"" + std::to_string(10 * k) + "\" y=\"" + std::to_string(100 + k) + "\"/>";
    last = static_cast<size_t>(it->position() + it->length());
  }
  out += xml.substr(last);
  ASSERT_GT(k, 5);
  auto v = plcopen_view(out);
  ASSERT_TRUE(v) << v.error();
  const json* main = pou(*v, "main");
  ASSERT_NE(main, nullptr);
  EXPECT_TRUE((*main)["positioned"].get<bool>());
  std::set<double> xs;
  for (const json& e : (*main)["elements"]) {
    EXPECT_EQ(static_cast<int>(e["y"].get<double>()) - 100, static_cast<int>(e["x"].get<double>()) / 10);
    xs.insert(e["x"].get<double>());
  }
  EXPECT_EQ(xs.size(), (*main)["elements"].size());
}

TEST(PlcopenView, refuses_what_the_reader_refuses_with_its_position) {
  auto v = plcopen_view("<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\"><types><pous><pou name=\"x\"></pou>",
                        "broken.xml");
  ASSERT_FALSE(v);
  EXPECT_NE(v.error().find("broken.xml:"), std::string::npos) << v.error();
}

}  // namespace
}  // namespace rtplc::editor
