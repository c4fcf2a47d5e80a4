// ajarctl blackbox (list, fetch, save: over the protocol; show, export: a local file) and ajarctl
// replay (replay.cpp). Private to ajar_ctl. docs/ajarctl.md, docs/blackbox.md.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "ajar/client/cli.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/recorder/mcap_reader.hpp"

namespace ajar::client {

int run_blackbox(const Command& command, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err);
int run_replay(const Command& command, const GlobalOptions& options, std::ostream& out,
               std::ostream& err);

// One message of a recording's wire channel (channels.hpp, kWireLayout), decoded.
struct WireRecord {
  std::uint64_t session_id = 0;
  bool in = false;  // received by ajard (a host's request); else sent by it
  std::uint64_t daemon_time_ns = 0;
  std::vector<std::uint8_t> frame;
  std::optional<protocol::Envelope> envelope;  // nullopt: the frame does not decode
  protocol::DecodeError error;                 // why not
};
// Every wire message of `file`, in file order; `problem` says what could not be read.
std::vector<WireRecord> wire_records(const recorder::McapFile& file, std::string* problem);

}  // namespace ajar::client
