// Internal to the state store (state_store.hpp): what its file formats share, and the reader of
// the text formats 1 and 2 (state_file_text.cpp).
#pragma once

#include <string>

#include "ajar/core/error.hpp"
#include "ajar/daemon/state_store.hpp"

namespace ajar::daemon::detail {

inline Error state_file_error(const std::string& message) {
  return make_error(ErrorCode::kInternal, "state_file", message);
}

// A latched fault as the engine latches it: kOk, or a known driver/motion fault (5xx).
inline bool is_restorable_fault(long long code) {
  if (code == 0) return true;
  if (code < 500 || code > 599) return false;
  return to_string(static_cast<ErrorCode>(code)) != "UNKNOWN";
}

// Formats 1 and 2 (text, checksum CRC-32), read only: what ajard wrote before format 3.
Result<StateRecord> decode_text_state(const std::string& text);

}  // namespace ajar::daemon::detail
