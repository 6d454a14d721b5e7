// The README stays true: every `sh` command block of README.md runs here, in
// README order, as one shell session in a scratch folder with its own runtime
// and state folders, and each command must do what the README says (succeed,
// or be refused where its comment says "refused"). Blocks tagged `sh-setup`
// (they install or build) and `sh-hardware` (a real PLC, bus or board) are
// not run; docs/testing.md says so for the reader.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_tool.h"
#include "tests/support/scratch.h"

namespace rtplc::test {
namespace {

const std::string kRepo = RTPLC_SOURCE_DIR;

struct Command {
  size_t line = 0;      // in README.md, 1-based
  std::string text;     // without its comment
  bool refused = false; // its comment says the runtime or the command refuses it
  bool may_fail = false; // its comment says when it exits 1 (`doctor` on a box not tuned yet)
};

// The command part of a README line: up to a '#' outside quotes that starts a
// comment (a '#' after a space).
std::string strip_comment(const std::string& l, std::string* comment) {
  char quote = 0;
  for (size_t i = 0; i < l.size(); ++i) {
    const char c = l[i];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '\'' || c == '"') {
      quote = c;
    } else if (c == '#' && (i == 0 || l[i - 1] == ' ')) {
      if (comment) *comment = l.substr(i);
      std::string cmd = l.substr(0, i);
      while (!cmd.empty() && cmd.back() == ' ') cmd.pop_back();
      return cmd;
    }
  }
  return l;
}

std::vector<Command> readme_commands(std::vector<std::string>* tags) {
  std::ifstream in(kRepo + "/README.md");
  std::vector<Command> out;
  std::string l;
  size_t n = 0;
  bool in_block = false, run = false;
  while (std::getline(in, l)) {
    ++n;
    if (l.rfind("```", 0) == 0) {
      if (!in_block) {
        const std::string tag = l.substr(3);
        tags->push_back(tag);
        run = tag == "sh";
      }
      in_block = !in_block;
      continue;
    }
    if (!in_block || !run) continue;
    std::string comment;
    Command c;
    c.line = n;
    c.text = strip_comment(l, &comment);
    c.refused = comment.find("refused") != std::string::npos;
    c.may_fail = comment.find("exit 1") != std::string::npos;
    if (!c.text.empty()) out.push_back(c);
  }
  return out;
}

// The runtime name a config gives (runtime.name), or rtplc.
std::string runtime_name_of(const std::string& config) {
  std::ifstream in(kRepo + "/" + config);
  std::string l;
  bool in_runtime = false;
  while (std::getline(in, l)) {
    if (l.rfind("runtime:", 0) == 0) in_runtime = true;
    else if (!l.empty() && l[0] != ' ' && l[0] != '#') in_runtime = false;
    else if (in_runtime && l.find("name:") != std::string::npos && l.find_first_not_of(' ') == l.find("name:")) {
      std::string v = l.substr(l.find("name:") + 5);
      v = strip_comment(v, nullptr);
      v.erase(0, v.find_first_not_of(' '));
      return v;
    }
  }
  return "rtplc";
}

std::string word_after(const std::string& text, const std::string& key) {
  const size_t p = text.find(key + " ");
  if (p == std::string::npos) return "";
  const size_t b = p + key.size() + 1;
  return text.substr(b, text.find(' ', b) - b);
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

TEST(Readme, every_command_block_runs_as_written) {
  std::vector<std::string> tags;
  const std::vector<Command> cmds = readme_commands(&tags);
  ASSERT_GT(cmds.size(), 20u) << "the README lost its command blocks";
  for (const std::string& t : tags) {
    EXPECT_TRUE(t == "sh" || t == "sh-setup" || t == "sh-hardware" || t == "text")
        << "a README block tagged '" << t << "': tag it sh (run by this test), sh-setup, sh-hardware or text";
  }
  Scratch s("rtplc-readme");
  ASSERT_EQ(mkdir(s.path("run").c_str(), 0700), 0);
  ASSERT_EQ(mkdir(s.path("state").c_str(), 0700), 0);
  std::string script =
      "set -u\n"
      "cd " + shell_quote(s.dir()) + "\n"
      "ln -s " + shell_quote(kRepo + "/examples") + " examples\n"
      "export PATH=" + shell_quote(std::string(RTPLC_BINARY_DIR)) + ":\"$PATH\"\n"
      "export RUNTIME_DIRECTORY=" + shell_quote(s.path("run")) + " STATE_DIRECTORY=" + shell_quote(s.path("state")) + "\n"
      "trap 'kill $(jobs -p) 2>/dev/null; wait 2>/dev/null' EXIT\n"
      "__up() { for i in $(seq 1 600); do rtplc status --name \"$1\" >/dev/null 2>&1 && return 0; sleep 0.1; done;"
      " echo \"runtime $1 did not come up\"; return 1; }\n"
      "__port() { for i in $(seq 1 600); do (exec 3<>/dev/tcp/127.0.0.1/$1) 2>/dev/null && return 0; sleep 0.1; done;"
      " echo \"nothing listens on port $1\"; return 1; }\n"
      "__fail() { echo \"README.md:$1: $2\"; exit 1; }\n";
  for (const Command& c : cmds) {
    const std::string where = std::to_string(c.line);
    script += "echo " + shell_quote("+ README.md:" + where + ": " + c.text) + "\n";
    if (!c.text.empty() && c.text.back() == '&') {
      script += c.text + "\n";
      if (c.text.rfind("rtplc run ", 0) == 0) {
        std::string name = word_after(c.text, "--name");
        if (name.empty()) name = runtime_name_of(word_after(c.text, "rtplc run"));
        script += "__up " + shell_quote(name) + " || __fail " + where + " 'did not start'\n";
      } else if (const std::string port = word_after(c.text, "--port"); !port.empty()) {
        script += "__port " + port + " || __fail " + where + " 'did not start listening'\n";
      }
    } else if (c.may_fail) {
      // Either answer is fine; dying of a signal (or a timeout) is not.
      script += "timeout 300 " + c.text + "; rc=$?; [ $rc -le 1 ] || __fail " + where + " \"exit $rc\"\n";
    } else if (c.refused) {
      script += "if timeout 300 " + c.text + "; then __fail " + where + " 'the README says this is refused'; fi\n";
    } else {
      script += "timeout 300 " + c.text + " || __fail " + where + " \"exit $?\"\n";
    }
  }
  script += "echo README-DONE\n";
  const std::string file = s.write("readme.sh", script);
  const ToolRun r = run_shell("bash " + file);
  EXPECT_NE(r.out.find("README-DONE"), std::string::npos) << r.out.substr(r.out.size() > 6000 ? r.out.size() - 6000 : 0);
}

}  // namespace
}  // namespace rtplc::test
