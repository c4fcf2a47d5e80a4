// Internal to the drivers that load a vendor library with dlopen (the GTS card, the card
// simulator's control API): a symbol of the library as a function pointer, or DriverStartupError
// naming the library ("<what> <path> lacks the symbol <name>").
#pragma once

#include <dlfcn.h>

#include <string>

#include "ajar/drivers/factory.hpp"

namespace ajar::drivers {

template <typename F>
F resolve_symbol(void* handle, const char* name, const char* what, const std::string& path) {
  dlerror();
  void* sym = dlsym(handle, name);
  if (sym == nullptr) {
    throw DriverStartupError(std::string(what) + " " + path + " lacks the symbol " + name);
  }
  return reinterpret_cast<F>(sym);
}

}  // namespace ajar::drivers
