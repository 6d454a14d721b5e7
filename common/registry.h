// A table that other files fill by registration (one driver kind per folder
// under io/drivers/, through io/drivers/registry.cpp), built on first use so a
// registration from a static initialiser works whatever the order in which
// files are initialised. Entries are objects that live for the whole program.
// The config side (config::DriverKind) and the runtime side (io::DriverKind)
// of the driver kinds each keep one.
#pragma once

#include <span>
#include <string_view>
#include <vector>

namespace rtplc {

template <class T>
class Registry {
 public:
  // Adds `entry` unless one of the same name (`name_of(entry)`) is there.
  template <class NameOf>
  static void add(const T* entry, NameOf name_of) {
    for (const T* e : table()) {
      if (std::string_view(name_of(*e)) == std::string_view(name_of(*entry))) return;
    }
    table().push_back(entry);
  }
  static std::span<const T* const> all() { return table(); }
  template <class NameOf>
  static const T* find(std::string_view name, NameOf name_of) {
    for (const T* e : table()) {
      if (std::string_view(name_of(*e)) == name) return e;
    }
    return nullptr;
  }

 private:
  static std::vector<const T*>& table() {
    static std::vector<const T*> entries;
    return entries;
  }
};

}  // namespace rtplc
