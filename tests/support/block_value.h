// A compiled program's block outputs by name, for tests that run an image
// with their own arena (several semantics, a migration): a number, or a
// STRING's text (a WSTRING's as UTF-8).
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "blocks/executor.h"
#include "blocks/string_ops.h"
#include "lang/compiler.h"

namespace rtplc::testing {

inline const Instr* block_named(const lang::CompileResult& r, std::string_view name) {
  for (size_t i = 0; i < r.image->blocks().size(); ++i) {
    if (r.image->str(r.image->blocks()[i].name) == name) return &r.image->code()[i];
  }
  ADD_FAILURE() << "no block " << name;
  return nullptr;
}

inline double block_value(const lang::CompileResult& r, const TaskArena& arena, std::string_view name) {
  const Instr* in = block_named(r, name);
  return in != nullptr ? arena.values[in->out] : -1.0;
}

inline std::string block_text(const lang::CompileResult& r, const TaskArena& arena, std::string_view name) {
  const Instr* in = block_named(r, name);
  if (in == nullptr) return "";
  return string_value(arena.values.data(), static_cast<uint32_t>(arena.values.size()), in->out,
                      writes_wide_string(*in, r.image->params().data() + in->param));
}

}  // namespace rtplc::testing
