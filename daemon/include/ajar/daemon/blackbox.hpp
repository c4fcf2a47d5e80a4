// The daemon's side of the black box (recorder/include/ajar/recorder/recorder.hpp; what is
// recorded: docs/blackbox.md): the recorder's settings from the config, and the JSON messages of
// channels.hpp made from the daemon's own types. Every record_* takes a null recorder (recording
// off) and then does nothing. I/O thread (or engine) side only: never called from the loop.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/protocol/messages.hpp"
#include "ajar/recorder/recorder.hpp"

namespace ajar::daemon {

// recorder.* of `config`; `monotonic_origin_ns`: the daemon's start (daemon_time_ns = 0).
recorder::RecorderSettings recorder_settings(const Config& config,
                                             std::int64_t monotonic_origin_ns);

// Status.recorder (protocol 1.2) from the recorder's atomics (never waits for its thread or the
// disk); a null recorder: disabled, mode off, all zero.
protocol::RecorderState recorder_state(const recorder::Recorder* r);

// /ajar/events, and /ajar/faults for fault_latched / fault_cleared.
void record_event(recorder::Recorder* r, const protocol::Event& event);
// /ajar/faults: a fault latched (or cleared) without an event, e.g. restored at start.
void record_fault(recorder::Recorder* r, std::uint64_t daemon_time_ns, bool latched, ErrorCode code,
                  std::string_view detail);
// /ajar/config: `reason` "start" or "reload"; the effective config as --check-config prints it.
void record_config(recorder::Recorder* r, std::uint64_t daemon_time_ns, std::string_view reason,
                   const Config& config, const std::vector<std::string>& changed_keys);
// /ajar/sessions: change "open", "close" or "role"; `identity` the TLS identity ("plaintext").
void record_session(recorder::Recorder* r, std::uint64_t daemon_time_ns, std::uint64_t session_id,
                    std::string_view change, std::string_view peer, std::string_view identity,
                    std::string_view role, std::string_view detail);
// /ajar/telemetry.
void record_telemetry(recorder::Recorder* r, const protocol::Telemetry& telemetry);

}  // namespace ajar::daemon
