// What the JSON and the text renderings of ajarctl's output share (client/src/output_*.cpp).
#pragma once

#include <string>

#include "ajar/protocol/messages.hpp"

namespace ajar::client::output {

inline std::string state_name(protocol::ProcedureState s) {
  return std::string(protocol::to_string(s));
}

}  // namespace ajar::client::output
