// Internal to the drivers that load a vendor library with dlopen (the GTS card, the card
// simulator's control API). `what` names the library in errors ("GTS card library").
#pragma once

#include <dlfcn.h>

#include <string>

#include "ajar/drivers/factory.hpp"

namespace ajar::drivers {

// dlopen(path) (RTLD_NOW | RTLD_LOCAL), or DriverStartupError "cannot load <what> <path>: <why>".
inline void* open_library(const char* what, const std::string& path) {
  dlerror();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    throw DriverStartupError("cannot load " + std::string(what) + " " + path + ": " +
                             (why != nullptr ? why : "unknown error"));
  }
  return handle;
}

// The symbols of a library open_library() opened, as function pointers; a missing one throws
// DriverStartupError "<what> <path> lacks the symbol <name>".
class LibrarySymbols {
 public:
  LibrarySymbols(void* handle, const char* what, const std::string& path)
      : handle_(handle), what_(what), path_(path) {}

  template <typename F>
  F get(const char* name) const {
    dlerror();
    void* sym = dlsym(handle_, name);
    if (sym == nullptr) {
      throw DriverStartupError(std::string(what_) + " " + path_ + " lacks the symbol " + name);
    }
    return reinterpret_cast<F>(sym);
  }

 private:
  void* handle_;
  const char* what_;
  std::string path_;
};

}  // namespace ajar::drivers
