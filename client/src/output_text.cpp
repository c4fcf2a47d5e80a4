// ajarctl's renderings for people (output.hpp): fixed-point numbers with units, one fact a line.
#include <cmath>
#include <cstdio>
#include <numbers>

#include "ajar/client/output.hpp"
#include "ajar/protocol/fields.hpp"
#include "output_fields.hpp"

namespace ajar::client {

// Fixed-point text with `digits` decimals; `sign` forces a leading + on positive values.
std::string fixed(double value, int digits, bool sign) {
  char buffer[64];
  if (sign) {
    std::snprintf(buffer, sizeof buffer, "%+.*f", digits, value);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  }
  return buffer;
}

std::string bytes_text(std::uint64_t n) {
  char text[32];
  if (n >= 10ULL << 30) {
    std::snprintf(text, sizeof text, "%.1f GiB", static_cast<double>(n) / 1073741824.0);
  } else if (n >= 10ULL << 20) {
    std::snprintf(text, sizeof text, "%.1f MiB", static_cast<double>(n) / 1048576.0);
  } else if (n >= 10ULL << 10) {
    std::snprintf(text, sizeof text, "%.1f KiB", static_cast<double>(n) / 1024.0);
  } else {
    std::snprintf(text, sizeof text, "%llu B", static_cast<unsigned long long>(n));
  }
  return text;
}

namespace {

using output::state_name;

// Status.recorder (1.2), two lines: what it writes where, and where every record went.
std::string recorder_text(const protocol::RecorderState& r) {
  std::string t = "black box:        " + std::string(protocol::to_string(r.mode));
  if (!r.enabled) t += " (recorder.enabled: false)";
  if (r.file.length > 0) t += ", " + std::string(r.file.view()) + " " + bytes_text(r.file_bytes);
  t += "; " + bytes_text(r.directory_bytes) + " of the " + bytes_text(r.max_bytes) + " budget, " +
       bytes_text(r.saved_bytes) + " saved, " + bytes_text(r.disk_free_bytes) + " free\n";
  t += "black box counts: " + std::to_string(r.records_written) + " written; loop " +
       std::to_string(r.loop_samples) + " samples, " + std::to_string(r.loop_dropped) +
       " dropped; I/O " + std::to_string(r.io_records) + " records, " +
       std::to_string(r.io_dropped) + " dropped; " + std::to_string(r.records_lost) +
       " lost to the disk (" + std::to_string(r.disk_refusals) + " refusals)";
  if (r.last_write_ns > 0)
    t += "; last write at " + fixed(static_cast<double>(r.last_write_ns) * 1e-9, 3) + " s";
  return t + "\n";
}

std::string m_text(double v) {
  return fixed(v, 4) + " m";
}
std::string rad(double v) {
  std::string t = fixed(v, 5, true);
  t += " rad (";
  t += fixed(v * 180.0 / std::numbers::pi, 3, true);
  t += " deg)";
  return t;
}
std::string vec(const core::Vec3& v) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.4f, %.4f, %.4f) m", v.x(), v.y(), v.z());
  return buffer;
}

std::string pad_key(std::string_view key) {
  std::string t(key);
  t += ':';
  if (t.size() < 32) t.append(32 - t.size(), ' ');
  return t;
}

std::string us(std::uint32_t ns) {
  return fixed(static_cast<double>(ns) * 1e-3, 1) + " us";
}

// Text of the MotionBlock, one line each (status) or compact (telemetry).
template <typename T>
std::string door_text(const T& m) {
  if (!m.door.has_distance) return "unknown";
  std::string t = m_text(m.door.distance_m) + " to the door";
  if (m.door.has_yaw) t += ", yaw to correct " + rad(m.door.yaw_rad);
  return t;
}

template <typename T>
std::string stale_text(const T& m) {
  std::string t;
  if (m.staleness.plane) t += "plane";
  if (m.staleness.contact) t += t.empty() ? "contact" : ", contact";
  if (t.empty()) t = "nothing";
  return t;
}

std::string window_text(const protocol::TimingWindow& w) {
  return "latency p99 " + us(w.latency.p99_ns) + " (max " + us(w.latency.max_ns) +
         "), execution p99 " + us(w.execution.p99_ns) + " (max " + us(w.execution.max_ns) +
         "), period p99 " + us(w.period.p99_ns) + ", " + std::to_string(w.samples) + " cycles";
}

}  // namespace

namespace {

// One line per field of RobotModel under its wire name; a block's or an array's values on its line
// ("left:  card_axis 1  polarity 1", "camera_to_base:  0  0  1  0.15 ...").
class ModelLines final : public protocol::FieldVisitor {
 public:
  std::string text;
  void field(std::string_view name, const protocol::FieldValue& value) override {
    const std::size_t end = std::min(name.find_first_of(".["), name.size());
    const std::string_view top = name.substr(0, end);
    if (top != top_) {
      if (!top_.empty()) text += "\n";
      text += pad_key(top);
      top_ = std::string(top);
    } else {
      text += "  ";
    }
    if (end < name.size() && name[end] == '.') text += std::string(name.substr(end + 1)) + " ";
    text += std::visit([](const auto& v) { return value_text(v); }, value);
  }

 private:
  static std::string value_text(double v) {
    char out[64];
    std::snprintf(out, sizeof out, "%.10g", v);
    return out;
  }
  static std::string value_text(float v) { return value_text(static_cast<double>(v)); }
  static std::string value_text(bool v) { return v ? "true" : "false"; }
  static std::string value_text(std::int64_t v) { return std::to_string(v); }
  static std::string value_text(std::uint64_t v) { return std::to_string(v); }
  static std::string value_text(const protocol::FieldWord& w) {
    return w.word.empty() ? std::to_string(w.raw) : std::string(w.word);
  }
  static std::string value_text(const protocol::FieldText& t) { return std::string(t.text); }
  static std::string value_text(std::span<const std::uint8_t> b) {
    return std::to_string(b.size()) + " bytes";
  }
  std::string top_;
};

}  // namespace

std::string robot_model_text(const protocol::RobotModel& model) {
  ModelLines lines;
  protocol::visit_fields(model, lines);
  return lines.text;
}

std::string status_text(const protocol::Status& s, std::uint8_t session_minor) {
  std::string t;
  t += "state:            " + state_name(s.state) + "\n";
  t += "latched fault:    " + std::string(ajar::to_string(s.latched_fault)) + "\n";
  t += "controller:       " + std::string(s.controller_connected ? "connected" : "none") + ", " +
       std::to_string(s.session_count) + " session(s)\n";
  if (s.has_width) {
    t += "door width:       " + m_text(s.width.length_m) + ", " +
         core::to_string(s.width.direction) + "\n";
  }
  if (s.has_handle) {
    t += "handle length:    " + m_text(s.handle.length_m) + ", " +
         core::to_string(s.handle.direction) + "\n";
  }
  if (s.has_plane) {
    t += "yaw deviation:    " + rad(s.plane.yaw_deviation_rad) + " from " +
         std::to_string(s.plane.point_count) + " points\n";
  }
  if (s.has_contact) t += "contact (base):   " + vec(s.contact.contact_base_m) + "\n";
  t += "odometry:         x " + fixed(s.odometry_x_m, 4, true) + " m, y " +
       fixed(s.odometry_y_m, 4, true) + " m, yaw " + rad(s.base_yaw_odometry_rad) + "\n";
  t += "door:             " + door_text(s) + "\n";
  t += "stale:            " + stale_text(s);
  if (s.has_plane)
    t += " (base moved " + m_text(s.staleness.travel_since_plane_m) + " since the plane)";
  t += "\n";
  t += "commanded:        " + fixed(s.commanded_linear_m_s, 3, true) + " m/s, " +
       fixed(s.commanded_angular_rad_s, 4, true) + " rad/s\n";
  t += "card / arm:       " + std::string(protocol::to_string(s.card)) + " / " +
       std::string(protocol::to_string(s.arm)) + " (" +
       std::string(protocol::to_string(s.arm_state)) + ")\n";
  t += "loop:             " + fixed(static_cast<double>(s.loop.rate_hz), 0) + " Hz, " +
       std::to_string(s.loop.cycles) + " cycles, " + std::to_string(s.loop.overruns) +
       " overruns; " + std::string(protocol::to_string(s.realtime.policy)) + " priority " +
       std::to_string(s.realtime.priority) +
       (s.realtime.memory_locked ? ", memory locked" : ", memory not locked") + "\n";
  t += "timing, recent:   (last " + fixed(static_cast<double>(s.timing.window_s), 1) + " s) " +
       window_text(s.timing.recent) + "\n";
  if (session_minor >= 2) {
    t += "base motion:      " + std::string(protocol::to_string(s.base_motion)) + "\n";
    t += recorder_text(s.recorder);
  }
  t += "timing, all:      " + window_text(s.timing.all);
  if (s.restored_from_disk) t += "\nparameters restored from disk";
  return t;
}

std::string response_text(std::string_view command, const Response& r) {
  const std::string cmd(command);
  switch (r.outcome) {
    case CallOutcome::kTimeout:
    case CallOutcome::kDisconnected:
      return cmd + ": " + std::string(to_string(r.outcome)) + ": " + r.transport_error;
    case CallOutcome::kRefused: {
      std::string t = cmd + ": refused: " + std::string(ajar::to_string(r.error.code));
      if (r.error.field.length > 0) t += " (" + std::string(r.error.field.view()) + ")";
      if (r.error.message.length > 0) t += ": " + std::string(r.error.message.view());
      return t;
    }
    case CallOutcome::kReply:
      break;
  }
  if (const auto* ack = r.get<protocol::Ack>()) {
    std::string t = cmd + ": ok, state " + state_name(ack->state);
    if (const auto* span = std::get_if<protocol::SpanAck>(&ack->body)) {
      t += ack->acknowledged == protocol::MessageType::kMeasureHandle ? "\n  handle length: "
                                                                      : "\n  door width:    ";
      t += m_text(span->length_m) + ", direction " + core::to_string(span->direction);
      t += "\n  p1 (base):     " + vec(span->p1_base_m);
      t += "\n  p2 (base):     " + vec(span->p2_base_m);
    } else if (const auto* plane = std::get_if<protocol::PlaneAck>(&ack->body)) {
      t += "\n  yaw deviation: " + rad(plane->yaw_deviation_rad);
      t += "\n  wheel angles:  left " + fixed(plane->left_wheel_rad, 5, true) + " rad, right " +
           fixed(plane->right_wheel_rad, 5, true) + " rad";
      t += "\n  wheel counts:  left " + std::to_string(plane->left_counts) + ", right " +
           std::to_string(plane->right_counts);
      t += "\n  plane fit:     " + std::to_string(plane->point_count) + " points, rms " +
           m_text(plane->rms_residual_m);
    } else if (const auto* contact = std::get_if<protocol::ContactAck>(&ack->body)) {
      t += "\n  contact (base): " + vec(contact->contact_base_m);
      t += "\n  reach margin:   " + m_text(contact->reach_margin_m);
    } else if (const auto* approach = std::get_if<protocol::ApproachAck>(&ack->body)) {
      t += "\n  travel:        " + fixed(approach->travel_m, 4, true) + " m (door now " +
           m_text(approach->start_distance_m) + " away)";
      t += "\n  wheel counts:  left " + std::to_string(approach->left_counts) + ", right " +
           std::to_string(approach->right_counts);
    }
    return t;
  }
  if (const auto* model = r.get<protocol::RobotModel>()) return robot_model_text(*model);
  if (const auto* status = r.get<protocol::Status>()) return status_text(*status, r.session_minor);
  if (r.get<protocol::Pong>()) return cmd + ": pong";
  if (const auto* w = r.get<protocol::Welcome>()) {
    return cmd + ": welcome, role " + std::string(protocol::to_string(w->granted_role)) +
           ", daemon " + std::string(w->daemon_version.view()) + ", drivers " +
           std::string(protocol::to_string(w->driver_kind));
  }
  return cmd + ": " + std::string(protocol::to_string(protocol::type_of(r.reply)));
}

std::string event_text(const protocol::Event& e) {
  std::string t =
      "event " + std::string(protocol::to_string(e.kind)) + ": state " + state_name(e.state);
  if (e.fault != ErrorCode::kOk) t += ", fault " + std::string(ajar::to_string(e.fault));
  if (e.detail.length > 0) t += ": " + std::string(e.detail.view());
  return t;
}

std::string telemetry_text(const protocol::Telemetry& tm) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "t=%.3f s %s%s odometry x %+.4f y %+.4f m yaw %+.5f rad, wheels L %+.5f R %+.5f "
                "rad (%lld / %lld counts), commanded %+.3f m/s %+.4f rad/s",
                static_cast<double>(tm.daemon_time_ns) * 1e-9, state_name(tm.state).c_str(),
                tm.moving ? " moving" : "", tm.odometry_x_m, tm.odometry_y_m,
                tm.base_yaw_odometry_rad, tm.left_wheel_rad, tm.right_wheel_rad,
                static_cast<long long>(tm.left_counts), static_cast<long long>(tm.right_counts),
                tm.commanded_linear_m_s, tm.commanded_angular_rad_s);
  std::string t = buffer;
  if (tm.door.has_distance) {
    t += ", door " + m_text(tm.door.distance_m);
    if (tm.door.has_yaw) t += " yaw " + fixed(tm.door.yaw_rad, 5, true) + " rad";
  }
  if (tm.staleness.plane || tm.staleness.contact) t += ", STALE " + stale_text(tm);
  t += ", loop " + fixed(static_cast<double>(tm.loop.rate_hz), 0) + " Hz latency p99 " +
       us(tm.timing.recent.latency.p99_ns) + " exec p99 " + us(tm.timing.recent.execution.p99_ns);
  return t;
}

}  // namespace ajar::client
