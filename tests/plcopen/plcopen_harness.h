// What the PLCopen importer's tests share: projects written in the habits of
// the editors (tc6_0201 with xhtml:p CDATA bodies), and a task image run
// cycle by cycle with its channels by label and its blocks by name.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "blocks/executor.h"
#include "sched/program.h"

namespace rtplc::lang {

inline std::string data(const char* f) { return std::string(RTPLC_PLCOPEN_DATA) + "/" + f; }

// A running image with access to its channels by label and blocks by name.
struct Machine {
  TaskImage img;
  TaskArena arena;
  explicit Machine(TaskImage i) : img(std::move(i)), arena(img) {}
  void set(const std::string& label, double v) {
    for (const Binding& b : img.bindings()) {
      if (b.dir != BindingDir::kOutput && img.str(b.label) == label) {
        arena.io_in[b.io_index] = v;
        return;
      }
    }
    ADD_FAILURE() << "no input " << label;
  }
  double out(const std::string& label) const {
    for (const Binding& b : img.bindings()) {
      if (b.dir == BindingDir::kOutput && img.str(b.label) == label) return arena.io_out[b.io_index];
    }
    ADD_FAILURE() << "no output " << label;
    return -1;
  }
  double value(const std::string& block) const {
    for (size_t s = 0; s < img.blocks().size(); ++s) {
      if (img.str(img.blocks()[s].name) == block) return arena.values[img.code()[s].out];
    }
    ADD_FAILURE() << "no block " << block;
    return -1;
  }
  void cycles(int n) {
    for (int i = 0; i < n; ++i) execute_cycle(img, arena);
  }
};

inline std::string project(const std::string& ns, const std::string& pous, const std::string& instances = "") {
  return "<?xml version=\"1.0\"?>\n<project xmlns=\"" + ns +
         "\" xmlns:xhtml=\"http://www.w3.org/1999/xhtml\">\n<fileHeader companyName=\"t\"/>\n"
         "<types><dataTypes/><pous>\n" + pous + "</pous></types>\n" + instances + "</project>\n";
}

inline std::string st_program(const std::string& vars, const std::string& body) {
  return "<pou name=\"main\" pouType=\"program\"><interface>" + vars +
         "</interface><body><ST><xhtml:p><![CDATA[" + body + "]]></xhtml:p></ST></body></pou>\n";
}

inline std::string var(const std::string& name, const std::string& type, const std::string& addr = "",
                const std::string& init = "") {
  return "<variable name=\"" + name + "\"" + (addr.empty() ? "" : " address=\"" + addr + "\"") + "><type><" +
         type + "/></type>" + (init.empty() ? "" : "<initialValue><simpleValue value=\"" + init + "\"/></initialValue>") +
         "</variable>";
}

// A variable of a function block or data type: fb("t1", "TON").
inline std::string fb(const char* name, const char* type) {
  return std::string("<variable name=\"") + name + "\"><type><derived name=\"" + type + "\"/></type></variable>";
}

inline const char* kNs201 = "http://www.plcopen.org/xml/tc6_0201";

}  // namespace rtplc::lang
