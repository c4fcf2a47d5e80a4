// The conformance suite's shared plumbing: the Suite (one check per line, PASS / FAIL / SKIP), the
// sessions it opens, frame surgery and the expectations. Each group of checks is defined in its own
// source file (see conformance.hpp). Private to this folder.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "ajar/client/client.hpp"
#include "ajar/client/json.hpp"
#include "ajar/conformance/conformance.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/vectors.hpp"

namespace ajar::conformance {

using Clock = std::chrono::steady_clock;
using client::CallOutcome;
using client::Client;
using client::ClientOptions;
using client::framed;
using client::json_number;
using client::json_vec3;
using client::Milliseconds;
using client::Response;
using protocol::MessageType;
using protocol::ProcedureState;
using protocol::Role;

// ---- Frame surgery -----------------------------------------------------------------------------

inline std::vector<std::uint8_t> frame_bytes(const protocol::Envelope& e,
                                             std::uint8_t minor = protocol::kVersionMinor) {
  std::vector<std::uint8_t> out;
  (void)protocol::encode_append(e, out, minor);
  return out;
}

inline void put_u16(std::vector<std::uint8_t>& f, std::size_t at, std::uint16_t v) {
  f[at] = static_cast<std::uint8_t>(v & 0xFF);
  f[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
inline void put_u32(std::vector<std::uint8_t>& f, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i)
    f[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Recomputes the CRC (the header before the CRC, then the payload) after a deliberate change.
inline void fix_crc(std::vector<std::uint8_t>& f) {
  std::vector<std::uint8_t> covered(f.begin(), f.begin() + protocol::kOffsetCrc);
  covered.insert(covered.end(), f.begin() + protocol::kHeaderSize, f.end());
  put_u32(f, protocol::kOffsetCrc, protocol::crc32c(covered));
}

inline void put_f64(std::vector<std::uint8_t>& f, std::size_t at, std::uint64_t bits) {
  for (std::size_t i = 0; i < 8; ++i)
    f[at + i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

// A check that cannot run against this daemon returns kSkip + why: counted as skipped, not passed.
inline constexpr std::string_view kSkip = "SKIP ";
inline std::string skip(const std::string& why) {
  return std::string(kSkip) + why;
}
// The daemon does not do Drive/Approach yet (protocol 1.1 lets it refuse them NOT_SUPPORTED).
inline std::string not_supported(const Response& r) {
  if (r.outcome == CallOutcome::kRefused && r.error.code == ErrorCode::kNotSupported) {
    return skip("skipped: daemon refuses with NOT_SUPPORTED (" +
                std::string(r.error.message.view()) + ")");
  }
  return {};
}

inline protocol::FramedPoint base_point(double x, double y, double z) {
  return framed(core::Frame::kBase, x, y, z);
}

// Points on a vertical door plane `distance_m` ahead, turned by `yaw_rad` (CCW), at lateral
// offset `lateral_m` and height `z_m` (base frame).
inline protocol::FramedPoint door_point(double distance_m, double yaw_rad, double lateral_m,
                                        double z_m, double proud_m = 0) {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  const double x = distance_m * c - lateral_m * s - proud_m * c;
  const double y = distance_m * s + lateral_m * c - proud_m * s;
  return base_point(x, y, z_m);
}

inline protocol::MeasureDoorPlane plane_of(std::initializer_list<protocol::FramedPoint> points) {
  protocol::MeasureDoorPlane m;
  m.count = static_cast<std::uint8_t>(points.size());
  std::copy(points.begin(), points.end(), m.points.begin());
  return m;
}

inline protocol::MeasureDoorPlane door_plane(double yaw_rad, double distance_m = 1.0) {
  return plane_of(
      {door_point(distance_m, yaw_rad, -0.3, 0.0), door_point(distance_m, yaw_rad, 0.3, 0.0),
       door_point(distance_m, yaw_rad, 0.25, 0.7), door_point(distance_m, yaw_rad, -0.2, 0.6)});
}

inline std::string describe(const Response& r) {
  if (r.outcome == CallOutcome::kRefused) {
    return std::string(ajar::to_string(r.error.code)) + " (field '" +
           std::string(r.error.field.view()) + "': " + std::string(r.error.message.view()) + ")";
  }
  if (r.outcome != CallOutcome::kReply) {
    return std::string(to_string(r.outcome)) + ": " + r.transport_error;
  }
  if (const auto* ack = r.get<protocol::Ack>()) {
    return "Ack, state " + std::string(protocol::to_string(ack->state));
  }
  return std::string(protocol::to_string(protocol::type_of(r.reply)));
}

inline std::string describe(const std::optional<protocol::Envelope>& e) {
  if (!e) return "no reply";
  if (const auto* err = std::get_if<protocol::ErrorReply>(&e->message)) {
    return "Error " + std::string(ajar::to_string(err->code)) + " (field '" +
           std::string(err->field.view()) + "')";
  }
  return std::string(protocol::to_string(protocol::type_of(e->message)));
}

// "" when `r` is an Error with `code` (and `field`, unless null).
inline std::string want_error(const Response& r, ErrorCode code, const char* field = nullptr) {
  if (r.outcome != CallOutcome::kRefused) {
    return "expected Error " + std::string(ajar::to_string(code)) + ", got " + describe(r);
  }
  if (r.error.code != code) {
    return "expected Error " + std::string(ajar::to_string(code)) + ", got " + describe(r);
  }
  if (field && r.error.field.view() != field) {
    return "expected field '" + std::string(field) + "', got '" +
           std::string(r.error.field.view()) + "'";
  }
  return {};
}

inline std::string want_error(const std::optional<protocol::Envelope>& e, ErrorCode code,
                              const char* field = nullptr, std::optional<std::uint32_t> id = {}) {
  const auto* err = e ? std::get_if<protocol::ErrorReply>(&e->message) : nullptr;
  if (!err || err->code != code) {
    return "expected Error " + std::string(ajar::to_string(code)) + ", got " + describe(e);
  }
  if (field && err->field.view() != field) {
    return "expected field '" + std::string(field) + "', got '" + std::string(err->field.view()) +
           "'";
  }
  if (id && e->request_id != *id) {
    return "expected request id " + std::to_string(*id) + ", got " + std::to_string(e->request_id);
  }
  return {};
}

template <typename T>
inline std::string want(const Response& r) {
  if (r.outcome == CallOutcome::kReply && r.get<T>()) return {};
  return "unexpected reply: " + describe(r);
}

inline std::string want_ack(const Response& r, ProcedureState state) {
  const auto* ack = r.get<protocol::Ack>();
  if (!ack) return "expected Ack, got " + describe(r);
  if (ack->state != state) {
    return "expected state " + std::string(protocol::to_string(state)) + ", got " +
           std::string(protocol::to_string(ack->state));
  }
  return {};
}

inline bool near(double a, double b, double tol) {
  return std::abs(a - b) <= tol;
}

// ---- The suite ---------------------------------------------------------------------------------

class Suite {
 public:
  Suite(const Options& options, std::ostream& out) : options_(options), out_(out) {}
  // Runs every group of checks in order; the last line is "N passed, N failed[, N skipped]".
  Result run();

 private:
  // ---- plumbing ----
  void check(const std::string& name, const std::function<std::string()>& body) {
    std::string why;
    try {
      why = body();
    } catch (const std::exception& e) {
      why = std::string("exception: ") + e.what();
    }
    if (why.empty()) {
      ++passed_;
      out_ << "PASS " << name << '\n';
    } else if (why.starts_with(kSkip)) {
      ++skipped_;
      out_ << "SKIP " << name << ": " << why.substr(kSkip.size()) << '\n';
    } else {
      ++failed_;
      out_ << "FAIL " << name << ": " << why << '\n';
    }
    out_.flush();
  }

  // A check that moves the base or the arm: skipped (with the reason) when motion is refused.
  void moving(const std::string& name, const std::function<std::string()>& body) {
    if (!motion_refused_.empty()) {
      check(name, [&] { return skip(motion_refused_); });
      return;
    }
    check(name, body);
  }

  std::unique_ptr<Client> open() {
    ClientOptions co;
    co.request_timeout = Milliseconds{static_cast<std::int64_t>(options_.timeout_s * 1000)};
    co.connect_timeout = std::max(co.request_timeout, Milliseconds{1000});
    co.retries = 0;
    co.tls = options_.tls;
    co.client_name = "ajarctl conformance";
    auto c = std::make_unique<Client>(co);
    if (!c->connect(options_.endpoint)) return nullptr;
    return c;
  }

  std::unique_ptr<Client> greeted(Role role, bool take_over = false) {
    auto c = open();
    if (!c) return nullptr;
    if (!c->hello(role, take_over).ok()) return nullptr;
    return c;
  }

  Milliseconds timeout() const {
    return Milliseconds{static_cast<std::int64_t>(options_.timeout_s * 1000)};
  }

  // Sends raw bytes and waits for the reply with `id` (any id if nullopt).
  std::optional<protocol::Envelope> raw(Client& c, const std::vector<std::uint8_t>& bytes,
                                        std::optional<std::uint32_t> id) {
    if (!c.send_raw(bytes)) return std::nullopt;
    return c.wait_reply(id, timeout());
  }

  // The session still answers: a Ping gets a Pong.
  std::string still_usable(Client& c) {
    const Response r = c.request(protocol::Ping{42});
    if (!r.get<protocol::Pong>()) return "session no longer usable: Ping got " + describe(r);
    if (r.get<protocol::Pong>()->client_time_ns != 42) return "Pong does not echo client_time_ns";
    return {};
  }

  std::optional<protocol::Status> status(Client& c) {
    const Response r = c.request(protocol::GetStatus{});
    if (const auto* s = r.get<protocol::Status>()) return *s;
    return std::nullopt;
  }

  // Waits while the state is `busy`, feeding the deadman by polling.
  std::optional<protocol::Status> wait_not(Client& c, ProcedureState busy, double seconds) {
    const auto deadline = Clock::now() + Milliseconds{static_cast<std::int64_t>(seconds * 1e3)};
    while (Clock::now() < deadline) {
      auto s = status(c);
      if (!s) return std::nullopt;
      if (s->state != busy) return s;
      std::this_thread::sleep_for(Milliseconds{20});
    }
    return std::nullopt;
  }

  void clean(const std::string& name) {
    check(name, [&] {
      auto c = greeted(Role::kController, true);
      if (!c) return std::string("cannot take control");
      (void)c->request(protocol::Stop{});
      const Response r = c->request(protocol::Reset{true});
      return want_ack(r, ProcedureState::kAwaitingWidth);
    });
  }

  // ---- driving (1.1): Drive and Approach ----
  // Keeps the newest Telemetry; shared with the client's callback (which may outlive a check).
  struct TelemetryWatch {
    std::mutex mutex;
    protocol::Telemetry last;
    std::uint64_t count = 0;
    double max_commanded_linear_m_s = 0;
  };
  struct EventWatch {
    std::mutex mutex;
    std::vector<protocol::EventKind> kinds;
  };

  static std::shared_ptr<TelemetryWatch> watch_telemetry(Client& c) {
    auto w = std::make_shared<TelemetryWatch>();
    c.on_telemetry([w](const protocol::Telemetry& t) {
      std::lock_guard lock(w->mutex);
      w->last = t;
      ++w->count;
      w->max_commanded_linear_m_s = std::max(w->max_commanded_linear_m_s, t.commanded_linear_m_s);
    });
    return w;
  }

  // Waits (bounded) for a Telemetry after `after_count` samples that shows the base at rest.
  static bool wait_at_rest(TelemetryWatch& w, std::uint64_t after_count, double seconds) {
    const auto deadline = Clock::now() + Milliseconds{static_cast<std::int64_t>(seconds * 1e3)};
    while (Clock::now() < deadline) {
      {
        std::lock_guard lock(w.mutex);
        if (w.count > after_count && !w.last.moving && w.last.commanded_linear_m_s == 0 &&
            w.last.commanded_angular_rad_s == 0) {
          return true;
        }
      }
      std::this_thread::sleep_for(Milliseconds{10});
    }
    return false;
  }

  // ---- the groups of checks, one source file each ----
  // ---- golden vectors ----
  void golden_vectors();
  std::string send_vector(const protocol::GoldenVector& v);
  // Its cases (vectors.cpp): a valid Hello on a fresh session; a valid request and an invalid
  // frame on the observer `c`. `request_id`: the vector's header's.
  std::string send_hello_vector(const protocol::GoldenVector& v, std::uint32_t request_id);
  std::string send_valid_vector(Client& c, const protocol::GoldenVector& v,
                                std::uint32_t request_id, MessageType type);
  std::string send_invalid_vector(Client& c, const protocol::GoldenVector& v,
                                  std::uint32_t request_id);
  // ---- decode errors built here (independent of the vector files) ----
  void decode_errors();
  void decode_header_errors();  // its parts (decode.cpp)
  void decode_payload_errors();
  void decode_framing();
  // ---- session rules ----
  void session_rules();
  void roles();
  void telemetry();
  // ---- order on the wire: replies before their events, zero-count motions (ordering.cpp) ----
  void ordering();
  // Its checks' bodies (ordering.cpp).
  std::string replies_before_their_events();
  std::string observer_take_over_keeps_control();
  std::string welcome_then_control_changed();
  // ---- the procedure, with every refusal on the way ----
  void procedure();
  // Its parts (procedure.cpp), on the controller `c`.
  void procedure_width_and_handle(Client& c);
  void procedure_plane(Client& c);
  void procedure_motion(Client& c);
  void refuse_keeping_state(Client& c, const std::string& name, const protocol::Message& m,
                            ErrorCode code, const char* field = nullptr);
  // ---- protocol 1.1: versions, the robot model, loop statistics ----
  // Says Hello 1.0 (header and payload minor 0) on `c` as an observer; "" when welcomed.
  std::string hello_1_0(Client& c);
  void protocol_1_1();
  void recordings();             // 1.2: the black box (recordings.cpp)
  void protocol_1_1_sessions();  // its parts (protocol_1_1.cpp)
  void protocol_1_1_new_types();
  void protocol_1_1_requests();
  void protocol_1_1_values();
  // "" when the model is plausible, else what is not.
  static std::string robot_model_problems(const protocol::RobotModel& m,
                                          const protocol::Welcome& w);
  // recordings()' checks' bodies (recordings.cpp). The listing sets `newest` (the newest recording,
  // if any) and `off` (why the checks that need the recorder are skipped).
  std::string list_recordings_unknown_to_1_1();
  std::string list_recordings_pages(std::optional<protocol::RecordingInfo>& newest,
                                    std::string& off);
  std::string recorder_status_agrees_with_list();
  std::string fetch_refuses_unknown_names();
  std::string fetch_refuses_bad_lengths(const std::optional<protocol::RecordingInfo>& newest);
  std::string fetch_starts_with_mcap_magic(const protocol::RecordingInfo& newest);
  std::string save_refuses_bad_ranges();
  // ---- driving (1.1): Drive and Approach ----
  void driving();
  // Its longer checks' bodies, on the controller `k` (driving.cpp).
  std::string drive_then_rest(Client& k, double timeout_s);
  std::string drive_times_out(Client& k, double timeout_s);
  std::string approach_to_standoff(Client& k, double min_standoff_m);
  std::string approach_ack_problem(const protocol::ApproachAck& ack, double start,
                                   double standoff) const;
  static std::optional<protocol::EventKind> wait_motion_end(EventWatch& events, double seconds);
  // ---- exactly-once execution ----
  void duplicates();
  // ---- latched faults ----
  void faults();
  // ---- garbage must not hurt other sessions ----
  void garbage();

  const Options& options_;
  std::ostream& out_;
  int passed_ = 0;
  int failed_ = 0;
  int skipped_ = 0;
  // Non-empty: the checks that move the base (or the arm) are refused, and this says why.
  std::string motion_refused_;
  std::optional<protocol::RobotModel> model_;
  double yaw_before_align_ = 0;
};

}  // namespace ajar::conformance
