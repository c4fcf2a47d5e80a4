// The daemon's side of the black box (blackbox.hpp): its types as the channels' JSON.
#include "ajar/daemon/blackbox.hpp"

#include <cmath>
#include <cstdio>

#include "ajar/recorder/channels.hpp"

namespace ajar::daemon {
namespace {

using recorder::json_string;

std::string number(double v) {
  if (!std::isfinite(v) || v == 0) return "0";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// Status.recorder.mode is the recorder's own mode, value for value.
constexpr bool same_modes() {
  using P = protocol::RecorderMode;
  using R = recorder::RecorderMode;
  return static_cast<int>(P::kOff) == static_cast<int>(R::kOff) &&
         static_cast<int>(P::kRecording) == static_cast<int>(R::kRecording) &&
         static_cast<int>(P::kDiskFull) == static_cast<int>(R::kDiskFull) &&
         static_cast<int>(P::kDiskError) == static_cast<int>(R::kDiskError) &&
         static_cast<int>(P::kNoDirectory) == static_cast<int>(R::kNoDirectory);
}
static_assert(same_modes());

}  // namespace

recorder::RecorderSettings recorder_settings(const Config& config,
                                             std::int64_t monotonic_origin_ns) {
  recorder::RecorderSettings s;
  const auto& c = config.recorder;
  s.enabled = c.enabled;
  s.directory = c.directory;
  s.max_bytes = static_cast<std::uint64_t>(c.max_bytes);
  s.max_file_bytes = static_cast<std::uint64_t>(c.max_file_bytes);
  s.max_file_s = c.max_file_s;
  s.loop_decimation = static_cast<std::uint32_t>(c.loop_decimation);
  s.monotonic_origin_ns = monotonic_origin_ns;
  s.write_delay_ms = c.debug_write_delay_ms;
  return s;
}

protocol::RecorderState recorder_state(const recorder::Recorder* r) {
  protocol::RecorderState s;
  if (r == nullptr) return s;  // no recorder: disabled, off
  const recorder::RecorderCounters c = r->counters();
  s.enabled = c.enabled;
  s.mode = static_cast<protocol::RecorderMode>(c.mode);  // the same values (recorder.hpp)
  s.file.assign(c.file);
  s.file_bytes = c.file_bytes;
  s.directory_bytes = c.directory_bytes;
  s.max_bytes = r->settings().max_bytes;
  s.saved_bytes = c.saved_bytes;
  s.disk_free_bytes = c.disk_free_bytes;
  s.records_written = c.messages_written;
  s.loop_samples = c.loop_samples;
  s.loop_dropped = c.loop_dropped;
  s.io_records = c.io_records;
  s.io_dropped = c.io_dropped;
  s.records_lost = c.write_failures;
  s.disk_refusals = c.disk_refusals;
  s.last_write_ns = c.last_write_ns;
  return s;
}

void record_event(recorder::Recorder* r, const protocol::Event& e) {
  if (r == nullptr) return;
  const std::string detail = json_string(e.detail.view());
  r->json(recorder::kEventsChannel, e.daemon_time_ns,
          "{\"daemon_time_ns\":" + std::to_string(e.daemon_time_ns) + ",\"kind\":\"" +
              std::string(protocol::to_string(e.kind)) + "\",\"state\":\"" +
              std::string(protocol::to_string(e.state)) + "\",\"fault\":\"" +
              std::string(to_string(e.fault)) + "\",\"detail\":" + detail + "}");
  if (e.kind == protocol::EventKind::kFaultLatched ||
      e.kind == protocol::EventKind::kFaultCleared) {
    record_fault(r, e.daemon_time_ns, e.kind == protocol::EventKind::kFaultLatched, e.fault,
                 e.detail.view());
  }
}

void record_fault(recorder::Recorder* r, std::uint64_t daemon_time_ns, bool latched, ErrorCode code,
                  std::string_view detail) {
  if (r == nullptr) return;
  r->json(recorder::kFaultsChannel, daemon_time_ns,
          "{\"daemon_time_ns\":" + std::to_string(daemon_time_ns) + ",\"change\":\"" +
              (latched ? "latched" : "cleared") + "\",\"code\":\"" + std::string(to_string(code)) +
              "\",\"code_number\":" + std::to_string(static_cast<unsigned>(code)) +
              ",\"detail\":" + json_string(detail) + "}");
}

void record_config(recorder::Recorder* r, std::uint64_t daemon_time_ns, std::string_view reason,
                   const Config& config, const std::vector<std::string>& changed_keys) {
  if (r == nullptr) return;
  std::string text = "{\"daemon_time_ns\":";
  text += std::to_string(daemon_time_ns);
  text += ",\"reason\":";
  text += json_string(reason);
  text += ",\"file\":";
  text += json_string(config.source_path);
  text += ",\"changed_keys\":[";
  for (std::size_t i = 0; i < changed_keys.size(); ++i) {
    if (i > 0) text += ',';
    text += json_string(changed_keys[i]);
  }
  text += "],\"yaml\":";
  text += json_string(to_yaml(config));
  text += '}';
  r->json(recorder::kConfigChannel, daemon_time_ns, std::move(text));
}

void record_session(recorder::Recorder* r, std::uint64_t daemon_time_ns, std::uint64_t session_id,
                    std::string_view change, std::string_view peer, std::string_view identity,
                    std::string_view role, std::string_view detail) {
  if (r == nullptr) return;
  r->json(recorder::kSessionsChannel, daemon_time_ns,
          "{\"daemon_time_ns\":" + std::to_string(daemon_time_ns) + ",\"session_id\":" +
              std::to_string(session_id) + ",\"change\":" + json_string(change) +
              ",\"peer\":" + json_string(peer) + ",\"identity\":" + json_string(identity) +
              ",\"role\":" + json_string(role) + ",\"detail\":" + json_string(detail) + "}");
}

void record_telemetry(recorder::Recorder* r, const protocol::Telemetry& t) {
  if (r == nullptr) return;
  r->json(recorder::kTelemetryChannel, t.daemon_time_ns,
          "{\"daemon_time_ns\":" + std::to_string(t.daemon_time_ns) + ",\"state\":\"" +
              std::string(protocol::to_string(t.state)) + "\",\"moving\":" +
              (t.moving ? "true" : "false") + ",\"left_wheel_rad\":" + number(t.left_wheel_rad) +
              ",\"right_wheel_rad\":" + number(t.right_wheel_rad) + ",\"base_yaw_odometry_rad\":" +
              number(t.base_yaw_odometry_rad) + ",\"odometry_x_m\":" + number(t.odometry_x_m) +
              ",\"odometry_y_m\":" + number(t.odometry_y_m) + ",\"arm_state\":\"" +
              std::string(protocol::to_string(t.arm_state)) +
              "\",\"commanded_linear_m_s\":" + number(t.commanded_linear_m_s) +
              ",\"commanded_angular_rad_s\":" + number(t.commanded_angular_rad_s) + "}");
}

}  // namespace ajar::daemon
