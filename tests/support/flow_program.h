// Flat programs with control flow built by hand (blocks/ops.h "Control
// flow"): what a textual front end emits for variables, branches and loops,
// for the tests of the executor, the verifier, the status lane and the runtime.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "blocks/registry.h"
#include "lang/flat_program.h"

namespace rtplc::testing {

// Appends blocks and returns their indices, so a test reads like the program.
struct Builder {
  lang::CheckedProgram p;

  uint32_t add(const std::string& written, const std::string& name, std::vector<uint32_t> in,
               std::vector<double> params = {}, uint32_t target = 0) {
    lang::FlatBlock b;
    b.spec = flow_block(written);  // nullptr for the FBD blocks: the checks look them up
    b.written = written;
    b.name = name;
    b.pos = SourcePos{static_cast<uint32_t>(p.blocks.size() + 1), 1};
    b.n_in = static_cast<uint32_t>(in.size());
    for (size_t k = 0; k < in.size(); ++k) b.in[k] = in[k];
    b.params = std::move(params);
    b.target = target;
    p.blocks.push_back(std::move(b));
    return static_cast<uint32_t>(p.blocks.size() - 1);
  }
  uint32_t var(const std::string& name, double init = 0) { return add("var", name, {}, {init}); }
  uint32_t k(const std::string& name, double v) { return add("const", name, {}, {v}); }
  uint32_t set(uint32_t var, uint32_t value) {
    return add("set", "set" + std::to_string(p.blocks.size()), {value}, {}, var);
  }
  uint32_t branch(const std::string& op, std::vector<uint32_t> cond, uint32_t target) {
    return add(op, op + std::to_string(p.blocks.size()), std::move(cond), {}, target);
  }
  uint32_t pick(std::vector<uint32_t> table, uint32_t index, double lo = 0) {
    const uint32_t b = add("pick", "pick" + std::to_string(p.blocks.size()), {index}, {lo});
    p.blocks[b].table = std::move(table);
    return b;
  }
  uint32_t put(std::vector<uint32_t> table, uint32_t index, uint32_t value, double lo = 0) {
    const uint32_t b = add("put", "put" + std::to_string(p.blocks.size()), {index, value}, {lo});
    p.blocks[b].table = std::move(table);
    return b;
  }
  // Patches a forward branch once its target exists.
  void aim(uint32_t branch_block, uint32_t target) { p.blocks[branch_block].target = target; }
  uint32_t next() const { return static_cast<uint32_t>(p.blocks.size()); }
  uint32_t out(uint32_t value, uint32_t c, const std::string& label = "") {
    lang::FlatBlock b;
    b.written = "dao";
    b.pos = SourcePos{static_cast<uint32_t>(p.blocks.size() + 1), 1};
    b.n_in = 1;
    b.in[0] = value;
    b.c = c;
    b.label = label.empty() ? "out" + std::to_string(c) : label;
    p.blocks.push_back(std::move(b));
    return static_cast<uint32_t>(p.blocks.size() - 1);
  }
  uint32_t setpoint(uint32_t c, double init, const std::string& label) {
    lang::FlatBlock b;
    b.written = "asp";
    b.name = "sp" + std::to_string(c);
    b.pos = SourcePos{static_cast<uint32_t>(p.blocks.size() + 1), 1};
    b.c = c;
    b.init = init;
    b.label = label;
    p.blocks.push_back(std::move(b));
    return static_cast<uint32_t>(p.blocks.size() - 1);
  }
  uint32_t in(uint32_t c) {
    lang::FlatBlock b;
    b.written = "dai";
    b.name = "in" + std::to_string(c);
    b.pos = SourcePos{static_cast<uint32_t>(p.blocks.size() + 1), 1};
    b.c = c;
    b.label = "in" + std::to_string(c);
    p.blocks.push_back(std::move(b));
    return static_cast<uint32_t>(p.blocks.size() - 1);
  }
};

}  // namespace rtplc::testing
