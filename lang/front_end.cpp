// The front-end registry and the one rule that picks a front end (front_end.h).
#include "lang/front_end.h"

#include <cstdlib>

#include "common/registry.h"

namespace rtplc::lang {

// lang/front_ends.cpp: the built-in languages.
void register_builtin_front_ends();

namespace {

using FrontEndTable = Registry<FrontEnd>;

const char* name_of(const FrontEnd& f) { return f.name; }

void ensure_builtins() {
  static const bool done = [] {
    register_builtin_front_ends();
    return true;
  }();
  (void)done;
}

}  // namespace

void register_front_end(const FrontEnd* front_end) { FrontEndTable::add(front_end, name_of); }

std::span<const FrontEnd* const> front_ends() {
  ensure_builtins();
  return FrontEndTable::all();
}

const FrontEnd& front_end_for(std::string_view path, std::string_view source) {
  const std::span<const FrontEnd* const> all = front_ends();
  for (const FrontEnd* f : all) {
    for (const char* ext : f->extensions) {
      const std::string_view e(ext);
      if (path.size() > e.size() && path.substr(path.size() - e.size()) == e) return *f;
    }
  }
  const FrontEnd* fallback = nullptr;
  for (const FrontEnd* f : all) {
    if (!f->recognises) {
      if (!fallback) fallback = f;
    } else if (f->recognises(source)) {
      return *f;
    }
  }
  if (!fallback) std::abort();  // lang/front_ends.cpp registers FBD as the fallback
  return *fallback;
}

}  // namespace rtplc::lang
