// The daemon's side of the black box (blackbox.hpp): its types as the channels' JSON.
#include "ajar/daemon/blackbox.hpp"

#include <cmath>
#include <chrono>
#include <cstdio>
#include <thread>

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
  if (c.debug_write_delay_ms > 0) {
    s.before_write = [ms = c.debug_write_delay_ms] {
      std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    };
  }
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
