// The one rule that picks a language (lang/front_end.h): a registered extension
// first, then the text, then the fallback; and a language added by one
// registration is compiled by the unchanged entry points.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <string_view>

#include "lang/compiler.h"
#include "lang/front_end.h"

namespace rtplc::lang {
namespace {

const char* kFbd = "%%\nF1 = asp(d0, c0, 50, \"SP\")\ndao(F1, p0, d0, c0, \"OUT\")\nEND\n";
const char* kSfcHeader = "// a chart\nSFC tank\n";
const char* kPlcopen = "<?xml version=\"1.0\"?>\n<!-- exported -->\n<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\">";

std::string name_for(std::string_view path, std::string_view text) { return front_end_for(path, text).name; }

TEST(FrontEnd, the_built_in_languages_are_registered_in_recognition_order_with_one_fallback) {
  std::vector<std::string> names;
  int fallbacks = 0;
  for (const FrontEnd* f : front_ends()) {
    names.emplace_back(f->name);
    fallbacks += f->recognises == nullptr;
  }
  ASSERT_GE(names.size(), 4u);
  EXPECT_EQ(names[0], "PLCopen XML");
  EXPECT_EQ(names[1], "SFC");
  EXPECT_EQ(names[2], "ST");
  EXPECT_EQ(names[3], "FBD");
  EXPECT_EQ(fallbacks, 1);
}

TEST(FrontEnd, text_decides_when_the_file_name_says_nothing) {
  EXPECT_EQ(name_for("", kFbd), "FBD");
  EXPECT_EQ(name_for("", kSfcHeader), "SFC");
  EXPECT_EQ(name_for("", kPlcopen), "PLCopen XML");
  EXPECT_EQ(name_for("plant.txt", kSfcHeader), "SFC");
  EXPECT_EQ(name_for("loop.fbd", kFbd), "FBD");
  EXPECT_EQ(name_for("", ""), "FBD");  // the fallback says what is wrong with an empty program
}

TEST(FrontEnd, a_registered_extension_decides_before_the_text) {
  EXPECT_EQ(name_for("tank.sfc", kFbd), "SFC");        // a chart without its SFC line: SFC's own errors
  EXPECT_EQ(name_for("tank.sfc", kPlcopen), "SFC");
  EXPECT_EQ(name_for("project.xml", kFbd), "PLCopen XML");
  EXPECT_EQ(name_for(".sfc", kFbd), "FBD");            // a bare extension is not a file name
}

TEST(FrontEnd, an_entry_is_refused_for_a_language_without_entries_naming_those_with) {
  CompileOptions o;
  o.entry = "Fast";
  const CompileResult r = compile_source(kFbd, o);
  ASSERT_FALSE(r.ok());
  const std::string msg = r.diags.items().at(0).message;
  EXPECT_NE(msg.find("of a PLCopen XML or ST project"), std::string::npos) << msg;
  EXPECT_NE(msg.find("this file is one FBD program"), std::string::npos) << msg;
}

// A language of one registration: "TOY" followed by an FBD body (its reader
// hands the rest to the FBD front end, as a real one would produce blocks).
const FrontEnd* fbd() {
  for (const FrontEnd* f : front_ends()) {
    if (f->recognises == nullptr) return f;
  }
  return nullptr;
}
CheckedProgram read_toy(std::string_view source, const CompileOptions& o, DiagnosticList& d) {
  return fbd()->read(source.substr(4), o, d);
}
bool is_toy(std::string_view s) { return s.substr(0, 4) == "TOY\n"; }
constexpr const char* kToyExtensions[] = {".toy"};
const FrontEnd kToy{.name = "Toy", .extensions = kToyExtensions, .recognises = is_toy, .has_entries = false,
                    .checks = FrontEnd::Checks::kRunByFrontEnd, .read = read_toy};

TEST(FrontEnd, a_new_language_is_one_registration_and_the_entry_points_compile_it) {
  register_front_end(&kToy);
  register_front_end(&kToy);  // once only
  int toys = 0;
  for (const FrontEnd* f : front_ends()) toys += std::string_view(f->name) == "Toy";
  EXPECT_EQ(toys, 1);

  const CompileResult from_text = compile_source(std::string("TOY\n") + kFbd);
  ASSERT_TRUE(from_text.ok()) << (from_text.diags.items().empty() ? "" : from_text.diags.items()[0].message);
  EXPECT_EQ(from_text.program.blocks.size(), 2u);

  const std::string path = ::testing::TempDir() + "front_end_test.toy";
  {
    std::ofstream f(path);
    f << "TOY\n" << kFbd;
  }
  const CompileResult from_file = compile_file(path);
  std::remove(path.c_str());
  ASSERT_TRUE(from_file.ok());
  EXPECT_EQ(name_for(path, "%%\nEND\n"), "Toy");  // its extension, whatever the text
}

}  // namespace
}  // namespace rtplc::lang
