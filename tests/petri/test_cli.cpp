// The built `rtplc analyze` on the PNML examples: output and exit codes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <string>

namespace {

struct CliRun {
  int code = -1;
  std::string out;
};

CliRun run(const std::string& args) {
  const std::string cmd = std::string(RTPLC_BINARY_DIR) + "/rtplc analyze " + args + " 2>&1";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

const std::string kExamples = std::string(RTPLC_SOURCE_DIR) + "/examples/petri/";

TEST(AnalyzeCli, reports_the_deadlock_of_the_example) {
  const CliRun r = run(kExamples + "deadlock.pnml");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("markings:   6\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dead markings (deadlocks): 1\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("after 2 firings: takeR1_A takeR2_B"), std::string::npos) << r.out;
}

TEST(AnalyzeCli, threads_give_the_same_figures) {
  // Kanban-4 (454,475 markings) passes the 100,000 where the parallel search takes over.
  const CliRun one = run("--generate kanban-4 --json -q --threads 1");
  const CliRun two = run("--generate kanban-4 --json -q --threads 2");
  ASSERT_EQ(one.code, 0) << one.out;
  ASSERT_EQ(two.code, 0) << two.out;
  EXPECT_NE(one.out.find("\"threads\": 1,"), std::string::npos) << one.out;
  EXPECT_NE(two.out.find("\"threads\": 2,"), std::string::npos) << two.out;
  for (const char* f : {"\"markings\": 454475,", "\"edges\": 3979850,", "\"dead_markings\": 0,",
                        "\"max_tokens_in_place\": 4,", "\"dead_transitions\": [],"}) {
    EXPECT_NE(one.out.find(f), std::string::npos) << f << "\n" << one.out;
    EXPECT_NE(two.out.find(f), std::string::npos) << f << "\n" << two.out;
  }
}

TEST(AnalyzeCli, threads_zero_is_refused) {
  const CliRun r = run("--generate kanban-1 --threads 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--threads"), std::string::npos) << r.out;
}

TEST(AnalyzeCli, json_has_the_required_fields) {
  const CliRun r = run(kExamples + "mutex.pnml --json");
  EXPECT_EQ(r.code, 0) << r.out;
  for (const char* f : {"\"places\": 5,", "\"transitions\": 4,", "\"markings\": 3,",
                        "\"edges\": 4,", "\"dead_markings\": 0,", "\"max_tokens_in_place\": 1,",
                        "\"safe\": true,", "\"dead_transitions\": [],"}) {
    EXPECT_NE(r.out.find(f), std::string::npos) << f << "\n" << r.out;
  }
}

TEST(AnalyzeCli, unbounded_example_shows_the_pump) {
  const CliRun r = run(kExamples + "producer.pnml");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("then pump: produce"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("buffer=omega"), std::string::npos) << r.out;
}

TEST(AnalyzeCli, limit_gives_exit_code_3) {
  const CliRun r = run("--generate philosophers-8 --limit 1000 -q");
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find("--limit"), std::string::npos);
}

TEST(AnalyzeCli, a_file_that_is_neither_pnml_nor_sfc_is_refused_saying_what_it_takes) {
  const std::string f = std::string(RTPLC_BINARY_DIR) + "/not_a_net.txt";
  std::ofstream(f) << "hello\n";
  const CliRun r = run(f);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("is neither PNML nor an SFC program"), std::string::npos) << r.out;
}

TEST(AnalyzeCli, a_broken_sfc_program_gets_positioned_errors) {
  const std::string f = std::string(RTPLC_BINARY_DIR) + "/not_a_net.sfc";
  std::ofstream(f) << "STEP s0\n";
  const CliRun r = run(f);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("not_a_net.sfc:1:1: error: an SFC program starts with 'SFC name'"),
            std::string::npos)
      << r.out;
}

TEST(AnalyzeCli, a_plcopen_sfc_pou_is_analysed_as_the_importer_reads_it) {
  const std::string f = std::string(RTPLC_SOURCE_DIR) + "/tests/plcopen/data/beremiz_sfc.xml";
  const CliRun r = run(f);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("SFC fill as a hierarchical Petri net"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("places: Idle(1) Filling Mixing Draining\n"), std::string::npos) << r.out;
  // The simultaneous branch: Mixing and Draining are active together, never deadlocked.
  EXPECT_NE(r.out.find("markings:   3\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dead markings (deadlocks): 0\n"), std::string::npos) << r.out;

  const CliRun no_pou = run(f + " --pou nope");
  EXPECT_EQ(no_pou.code, 1);
  EXPECT_NE(no_pou.out.find("no POU 'nope' with an SFC body; the project has fill"),
            std::string::npos)
      << no_pou.out;
  const CliRun not_plcopen = run(kExamples + "mutex.pnml --pou fill");
  EXPECT_EQ(not_plcopen.code, 2) << not_plcopen.out;
}

TEST(AnalyzeCli, a_textual_sfc_in_a_st_file_is_the_same_chart) {
  const CliRun r = run(std::string(RTPLC_SOURCE_DIR) + "/examples/filler_sfc.st");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("SFC Filler as a hierarchical Petri net"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("places: Idle(1) Fill Drain\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dead markings (deadlocks): 0\n"), std::string::npos) << r.out;
  const CliRun no_pou = run(std::string(RTPLC_SOURCE_DIR) + "/examples/filler_sfc.st --pou nope");
  EXPECT_EQ(no_pou.code, 1) << no_pou.out;
  EXPECT_NE(no_pou.out.find("no POU 'nope' with an SFC body; the project has Filler"), std::string::npos) << no_pou.out;
}

TEST(AnalyzeCli, bad_pnml_shows_file_line_col) {
  const std::string f = std::string(RTPLC_BINARY_DIR) + "/broken.pnml";
  std::ofstream(f) << "<pnml>\n<net id=\"n\" "
                      "type=\"http://www.pnml.org/version-2009/grammar/ptnet\">\n<page>\n</net>";
  const CliRun r = run(f);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("broken.pnml:4:1: error"), std::string::npos) << r.out;
}

TEST(AnalyzeCli, writes_pnml_and_dot) {
  const std::string pn = std::string(RTPLC_BINARY_DIR) + "/k1.pnml";
  const std::string dot = std::string(RTPLC_BINARY_DIR) + "/k1.dot";
  CliRun r = run("--generate kanban-1 -q --write-pnml " + pn);
  EXPECT_EQ(r.code, 0) << r.out;
  r = run(pn + " --dot " + dot);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("markings:   160\n"), std::string::npos) << r.out;
  std::ifstream d(dot);
  const std::string text((std::istreambuf_iterator<char>(d)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("digraph"), std::string::npos);
  EXPECT_NE(text.find("tsynch1_23"), std::string::npos);
}

}  // namespace
