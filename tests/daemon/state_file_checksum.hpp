// A state file body signed with its checksum line, computed here independently of the daemon's
// writer (the format: daemon/include/ajar/daemon/state_store.hpp): a file that passes the checksum
// whatever its content, for the tests of what the daemon refuses to restore.
#pragma once

#include <cstdio>
#include <string>

#include <boost/crc.hpp>

namespace ajar::testing {

inline std::string with_checksum(const std::string& body) {
  boost::crc_32_type crc;
  crc.process_bytes(body.data(), body.size());
  char line[32];
  std::snprintf(line, sizeof(line), "crc32 %08x\n", crc.checksum());
  return body + line;
}

}  // namespace ajar::testing
