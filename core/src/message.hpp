// Internal to ajar_core: printf-style formatting of error messages into a std::string.
// Pure (formats into memory; nothing is written anywhere).
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

#include "ajar/core/result.hpp"

namespace ajar::core::detail {

[[gnu::format(printf, 1, 2)]] inline std::string format(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  va_list copy;
  va_copy(copy, args);
  const int needed = std::vsnprintf(nullptr, 0, fmt, copy);
  va_end(copy);
  std::string out;
  if (needed > 0) {
    out.resize(static_cast<std::size_t>(needed) + 1);
    std::vsnprintf(out.data(), out.size(), fmt, args);
    out.resize(static_cast<std::size_t>(needed));
  }
  va_end(args);
  return out;
}

inline Error error(ErrorCode code, std::string field, std::string message) {
  return Error{code, std::move(field), std::move(message)};
}

}  // namespace ajar::core::detail
