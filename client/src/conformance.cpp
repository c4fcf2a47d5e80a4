#include "ajar/client/conformance.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <ostream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include <Eigen/LU>

#include "ajar/client/cli.hpp"
#include "ajar/client/client.hpp"
#include "ajar/client/output.hpp"
#include "ajar/client/teleop.hpp"
#include "ajar/protocol/vectors.hpp"

namespace ajar::client {

namespace {

using Clock = std::chrono::steady_clock;
using protocol::MessageType;
using protocol::ProcedureState;
using protocol::Role;

// ---- Frame surgery -----------------------------------------------------------------------------

std::vector<std::uint8_t> frame_bytes(const protocol::Envelope& e,
                                      std::uint8_t minor = protocol::kVersionMinor) {
  std::vector<std::uint8_t> out;
  (void)protocol::encode_append(e, out, minor);
  return out;
}

void put_u16(std::vector<std::uint8_t>& f, std::size_t at, std::uint16_t v) {
  f[at] = static_cast<std::uint8_t>(v & 0xFF);
  f[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(std::vector<std::uint8_t>& f, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i)
    f[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Recomputes the CRC (header bytes 0..17, then the payload) after a deliberate change.
void fix_crc(std::vector<std::uint8_t>& f) {
  std::vector<std::uint8_t> covered(f.begin(), f.begin() + 18);
  covered.insert(covered.end(), f.begin() + 22, f.end());
  put_u32(f, 18, protocol::crc32c(covered));
}

void put_f64(std::vector<std::uint8_t>& f, std::size_t at, std::uint64_t bits) {
  for (std::size_t i = 0; i < 8; ++i)
    f[at + i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

// A check that cannot run against this daemon returns kSkip + why: counted as skipped, not passed.
constexpr std::string_view kSkip = "SKIP ";
std::string skip(const std::string& why) {
  return std::string(kSkip) + why;
}
// The daemon does not do Drive/Approach yet (protocol 1.1 lets it refuse them NOT_SUPPORTED).
std::string not_supported(const Response& r) {
  if (r.outcome == Outcome::kRefused && r.error.code == ErrorCode::kNotSupported) {
    return skip("skipped: daemon refuses with NOT_SUPPORTED (" +
                std::string(r.error.message.view()) + ")");
  }
  return {};
}

protocol::FramedPoint base_point(double x, double y, double z) {
  return framed(core::Frame::kBase, x, y, z);
}

// Points on a vertical door plane `distance_m` ahead, turned by `yaw_rad` (CCW), at lateral
// offset `lateral_m` and height `z_m` (base frame).
protocol::FramedPoint door_point(double distance_m, double yaw_rad, double lateral_m, double z_m,
                                 double proud_m = 0) {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  const double x = distance_m * c - lateral_m * s - proud_m * c;
  const double y = distance_m * s + lateral_m * c - proud_m * s;
  return base_point(x, y, z_m);
}

protocol::MeasureDoorPlane plane_of(std::initializer_list<protocol::FramedPoint> points) {
  protocol::MeasureDoorPlane m;
  m.count = static_cast<std::uint8_t>(points.size());
  std::copy(points.begin(), points.end(), m.points.begin());
  return m;
}

protocol::MeasureDoorPlane door_plane(double yaw_rad, double distance_m = 1.0) {
  return plane_of(
      {door_point(distance_m, yaw_rad, -0.3, 0.0), door_point(distance_m, yaw_rad, 0.3, 0.0),
       door_point(distance_m, yaw_rad, 0.25, 0.7), door_point(distance_m, yaw_rad, -0.2, 0.6)});
}

std::string describe(const Response& r) {
  if (r.outcome == Outcome::kRefused) {
    return std::string(ajar::to_string(r.error.code)) + " (field '" +
           std::string(r.error.field.view()) + "': " + std::string(r.error.message.view()) + ")";
  }
  if (r.outcome != Outcome::kReply) {
    return std::string(to_string(r.outcome)) + ": " + r.transport_error;
  }
  if (const auto* ack = r.get<protocol::Ack>()) {
    return "Ack, state " + std::string(protocol::to_string(ack->state));
  }
  return std::string(protocol::to_string(protocol::type_of(r.reply)));
}

std::string describe(const std::optional<protocol::Envelope>& e) {
  if (!e) return "no reply";
  if (const auto* err = std::get_if<protocol::ErrorReply>(&e->message)) {
    return "Error " + std::string(ajar::to_string(err->code)) + " (field '" +
           std::string(err->field.view()) + "')";
  }
  return std::string(protocol::to_string(protocol::type_of(e->message)));
}

// "" when `r` is an Error with `code` (and `field`, unless null).
std::string want_error(const Response& r, ErrorCode code, const char* field = nullptr) {
  if (r.outcome != Outcome::kRefused) {
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

std::string want_error(const std::optional<protocol::Envelope>& e, ErrorCode code,
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
std::string want(const Response& r) {
  if (r.outcome == Outcome::kReply && r.get<T>()) return {};
  return "unexpected reply: " + describe(r);
}

std::string want_ack(const Response& r, ProcedureState state) {
  const auto* ack = r.get<protocol::Ack>();
  if (!ack) return "expected Ack, got " + describe(r);
  if (ack->state != state) {
    return "expected state " + std::string(protocol::to_string(state)) + ", got " +
           std::string(protocol::to_string(ack->state));
  }
  return {};
}

bool near(double a, double b, double tol) {
  return std::abs(a - b) <= tol;
}

// ---- The suite ---------------------------------------------------------------------------------

class Suite {
 public:
  Suite(const GlobalOptions& options, std::string vectors_dir, bool allow_motion_on_real_robot,
        std::ostream& out)
      : options_(options),
        vectors_dir_(std::move(vectors_dir)),
        allow_motion_on_real_robot_(allow_motion_on_real_robot),
        out_(out) {}

  int run() {
    // Reachability first: nothing else makes sense without it.
    {
      auto c = open();
      if (!c) {
        out_ << "FAIL connect: cannot reach " << options_.endpoint.host << ":"
             << options_.endpoint.port << "\n0 passed, 1 failed\n";
        return kExitConnection;
      }
    }
    // Which drivers: the checks that move the base refuse to run on real hardware unless told.
    {
      auto c = open();
      const Response r = c ? c->hello(Role::kObserver) : Response{};
      const auto* w = r.get<protocol::Welcome>();
      std::optional<protocol::DriverKind> kind;
      if (w && w->version_minor >= 1) kind = w->driver_kind;
      motion_refused_ = motion_refusal(kind, allow_motion_on_real_robot_);
      out_ << "daemon drivers: "
           << (kind ? std::string(protocol::to_string(*kind)) : std::string("not said (1.0)"))
           << '\n';
      if (!motion_refused_.empty()) out_ << "REFUSED motion checks: " << motion_refused_ << '\n';
    }
    clean("initial reset");
    golden_vectors();
    decode_errors();
    session_rules();
    protocol_1_1();
    roles();
    telemetry();
    procedure();
    driving();
    duplicates();
    faults();
    garbage();
    clean("final reset (clean state)");
    check("final state clean", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      const Response r = c->request(protocol::GetStatus{});
      const auto* s = r.get<protocol::Status>();
      if (!s) return "GetStatus: " + describe(r);
      if (s->state != ProcedureState::kAwaitingWidth || s->latched_fault != ErrorCode::kOk ||
          s->has_width || s->has_handle || s->has_plane || s->has_contact) {
        return "state " + std::string(protocol::to_string(s->state)) + ", fault " +
               std::string(ajar::to_string(s->latched_fault));
      }
      return std::string{};
    });
    if (!motion_refused_.empty()) out_ << "REFUSED motion checks: " << motion_refused_ << '\n';
    out_ << passed_ << " passed, " << failed_ << " failed";
    if (skipped_ > 0) out_ << ", " << skipped_ << " skipped";
    out_ << '\n';
    out_.flush();
    return failed_ == 0 ? kExitOk : kExitRefused;
  }

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
    if (!c->connect(options_.endpoint).empty()) return nullptr;
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

  // ---- golden vectors ----
  void golden_vectors() {
    namespace fs = std::filesystem;
    std::vector<fs::path> files;
    std::error_code ec;
    if (fs::is_directory(vectors_dir_, ec)) {
      for (const auto& entry : fs::directory_iterator(vectors_dir_, ec)) {
        if (entry.path().extension() == ".vec") files.push_back(entry.path());
      }
    }
    std::sort(files.begin(), files.end());
    check("vectors: found in " + vectors_dir_, [&] {
      return files.empty() ? std::string("no *.vec files (use --vectors DIR)") : std::string{};
    });
    for (const auto& path : files) {
      std::ifstream f(path);
      std::stringstream text;
      text << f.rdbuf();
      auto parsed = protocol::parse_vector(text.str());
      const std::string name = "vector " + path.stem().string();
      if (!parsed) {
        check(name + ": parse", [&] { return parsed.error().message; });
        continue;
      }
      const protocol::GoldenVector& v = *parsed;
      check(name + ": this client's codec", [&] {
        auto s = protocol::check_vector(v);
        return s ? std::string{} : s.error().message;
      });
      if (v.direction == protocol::GoldenVector::Direction::kHostToDaemon) {
        check(name + ": daemon", [&] { return send_vector(v); });
      }
    }
  }

  std::string send_vector(const protocol::GoldenVector& v) {
    std::array<std::uint8_t, protocol::kHeaderSize> header{};
    std::copy_n(v.bytes.begin(), std::min(v.bytes.size(), header.size()), header.begin());
    const protocol::FrameHeader h = protocol::decode_header(header);
    const auto type = static_cast<MessageType>(h.type);
    if (v.expect_ok && type == MessageType::kHello) {
      // As the first frame of a fresh session; no controller holds control at this point.
      auto c = open();
      if (!c) return "cannot connect";
      auto reply = raw(*c, v.bytes, h.request_id);
      if (!reply || !std::holds_alternative<protocol::Welcome>(reply->message)) {
        return "expected Welcome with request id " + std::to_string(h.request_id) + ", got " +
               describe(reply);
      }
      return {};
    }
    auto c = greeted(Role::kObserver);
    if (!c) return "cannot open an observer session";
    if (v.expect_ok) {
      auto reply = raw(*c, v.bytes, h.request_id);
      if (!reply) return "no reply with request id " + std::to_string(h.request_id);
      const auto* err = std::get_if<protocol::ErrorReply>(&reply->message);
      switch (type) {
        case MessageType::kPing:
          if (!std::holds_alternative<protocol::Pong>(reply->message))
            return "got " + describe(reply);
          break;
        case MessageType::kGetStatus:
          if (!std::holds_alternative<protocol::Status>(reply->message)) {
            return "got " + describe(reply);
          }
          break;
        case MessageType::kGetRobotModel:
          if (!std::holds_alternative<protocol::RobotModel>(reply->message)) {
            return "got " + describe(reply);
          }
          break;
        case MessageType::kSubscribe:
        case MessageType::kStop:
        case MessageType::kEmergencyStop:
          if (!std::holds_alternative<protocol::Ack>(reply->message))
            return "got " + describe(reply);
          break;
        default:  // commands: decoded, then refused by the session rules (observer)
          if (!err || err->code != ErrorCode::kNotController) {
            return "expected Error NOT_CONTROLLER (decoded, observer), got " + describe(reply);
          }
      }
      if (type == MessageType::kEmergencyStop) {
        auto ctl = greeted(Role::kController, true);
        if (!ctl || !ctl->request(protocol::Reset{false}).ok()) return "cannot Reset after it";
      }
      if (type == MessageType::kSubscribe) (void)c->request(protocol::Subscribe{});
      return still_usable(*c);
    }
    const std::string code(ajar::to_string(v.expected_error));
    auto reply = raw(*c, v.bytes, std::nullopt);
    const auto* err = reply ? std::get_if<protocol::ErrorReply>(&reply->message) : nullptr;
    if (!err || err->code != v.expected_error)
      return "expected Error " + code + ", got " + describe(reply);
    if (!v.field.empty() && err->field.view() != v.field) {
      return "expected field '" + v.field + "', got '" + std::string(err->field.view()) + "'";
    }
    if (v.framing_lost) {
      if (!c->wait_closed(timeout())) return "connection not closed after framing was lost";
      return {};
    }
    if (v.expected_error != ErrorCode::kCrcMismatch && reply->request_id != h.request_id) {
      return "reply request id " + std::to_string(reply->request_id) + ", expected " +
             std::to_string(h.request_id);
    }
    return still_usable(*c);
  }

  // ---- decode errors built here (independent of the vector files) ----
  void decode_errors() {
    auto ping_frame = [&](std::uint32_t id) {
      return frame_bytes(protocol::Envelope{id, 0, protocol::Ping{7}});
    };
    check("decode: CRC_MISMATCH is refused, not executed, session continues", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9001);
      f.back() ^= 0x01;
      if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kCrcMismatch, "header.crc");
          !e.empty()) {
        return e;
      }
      return still_usable(*c);
    });
    check("decode: UNKNOWN_MESSAGE_TYPE (0x01ff) keeps the session usable", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9002);
      put_u16(f, 6, 0x01ff);
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, 9002), ErrorCode::kUnknownMessageType, nullptr, 9002);
          !e.empty()) {
        return e;
      }
      return still_usable(*c);
    });
    check("decode: a daemon-to-host type sent to the daemon is UNKNOWN_MESSAGE_TYPE", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      const auto f = frame_bytes(protocol::Envelope{9003, 0, protocol::Pong{1, 2}});
      if (auto e = want_error(raw(*c, f, 9003), ErrorCode::kUnknownMessageType); !e.empty())
        return e;
      return still_usable(*c);
    });
    check("decode: UNKNOWN_FLAGS refuses the frame (not executed)", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9004);
      put_u16(f, 8, 0x0004);
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, 9004), ErrorCode::kUnknownFlags, "header.flags", 9004);
          !e.empty()) {
        return e;
      }
      return still_usable(*c);
    });
    check("decode: BAD_PAYLOAD_LENGTH (Ping with 7 bytes)", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9005);
      f.pop_back();
      put_u32(f, 14, 7);
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, 9005), ErrorCode::kBadPayloadLength, nullptr, 9005);
          !e.empty()) {
        return e;
      }
      return still_usable(*c);
    });
    check("decode: NON_FINITE_NUMBER (NaN in p2.z), nothing executed", [&] {
      auto c = greeted(Role::kController, true);
      if (!c) return std::string("cannot connect");
      protocol::MeasureDoorWidth m{base_point(1, 0.4, 0), base_point(1, -0.4, 0)};
      auto f = frame_bytes(protocol::Envelope{c->next_request_id(), 0, m});
      // p2.z is the last 8 payload bytes: a quiet NaN.
      const std::uint64_t nan_bits = 0x7ff8000000000000ull;
      for (std::size_t i = 0; i < 8; ++i) {
        f[f.size() - 8 + i] = static_cast<std::uint8_t>(nan_bits >> (8 * i));
      }
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kNonFiniteNumber, "p2.z");
          !e.empty()) {
        return e;
      }
      const auto s = status(*c);
      if (!s || s->has_width) return std::string("a width was stored");
      return std::string{};
    });
    check("decode: INVALID_ENUM_VALUE (points[1].frame = 7)", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = frame_bytes(protocol::Envelope{9007, 0, door_plane(0.1)});
      f[22 + 1 + 25] = 7;
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, 9007), ErrorCode::kInvalidEnumValue, "points[1].frame");
          !e.empty()) {
        return e;
      }
      return still_usable(*c);
    });
    check("decode: BAD_COUNT (plane with count 2)", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = frame_bytes(protocol::Envelope{9008, 0, door_plane(0.1)});
      f[22] = 2;
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, 9008), ErrorCode::kBadCount, "count"); !e.empty())
        return e;
      return still_usable(*c);
    });
    check("decode: BAD_STRING (control character in client_name)", [&] {
      auto c = open();
      if (!c) return std::string("cannot connect");
      protocol::Hello hello;
      hello.client_name = "abc";
      auto f = frame_bytes(protocol::Envelope{9009, 0, hello});
      f[22 + 12 + 2] = 0x07;
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, 9009), ErrorCode::kBadString, "client_name"); !e.empty()) {
        return e;
      }
      // The refused Hello did not greet the session.
      if (auto e = want_error(c->request(protocol::GetStatus{}), ErrorCode::kHelloRequired);
          !e.empty()) {
        return e;
      }
      return std::string{};
    });
    check("decode: UNSUPPORTED_VERSION in the header closes the connection", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9010);
      f[4] = 2;
      fix_crc(f);
      if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kUnsupportedVersion);
          !e.empty()) {
        return e;
      }
      return c->wait_closed(timeout()) ? std::string{} : std::string("connection not closed");
    });
    check("decode: PAYLOAD_TOO_LARGE closes the connection", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9011);
      put_u32(f, 14, 1025);
      if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kPayloadTooLarge); !e.empty()) {
        return e;
      }
      return c->wait_closed(timeout()) ? std::string{} : std::string("connection not closed");
    });
    check("decode: BAD_MAGIC closes the connection", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      const std::vector<std::uint8_t> junk{'G', 'E', 'T', ' ', '/', ' ', 'H', 'T', 'T', 'P'};
      if (auto e = want_error(raw(*c, junk, std::nullopt), ErrorCode::kBadMagic, "header.magic");
          !e.empty()) {
        return e;
      }
      return c->wait_closed(timeout()) ? std::string{} : std::string("connection not closed");
    });
    check("decode: a frame split into single bytes is decoded", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      const auto f = ping_frame(9012);
      for (std::uint8_t b : f)
        c->send_raw(std::span<const std::uint8_t>(&b, 1));
      auto reply = c->wait_reply(9012, timeout());
      if (!reply || !std::holds_alternative<protocol::Pong>(reply->message)) {
        return "got " + describe(reply);
      }
      return std::string{};
    });
    check("decode: two frames in one write are both answered, in order", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      auto f = ping_frame(9013);
      const auto g = frame_bytes(protocol::Envelope{9014, 0, protocol::GetStatus{}});
      f.insert(f.end(), g.begin(), g.end());
      c->send_raw(f);
      auto first = c->wait_reply(std::nullopt, timeout());
      auto second = c->wait_reply(std::nullopt, timeout());
      if (!first || first->request_id != 9013 || !second || second->request_id != 9014) {
        return std::string("replies missing or out of order");
      }
      return std::string{};
    });
  }

  // ---- session rules ----
  void session_rules() {
    check("session: requests before Hello get HELLO_REQUIRED; the session stays open", [&] {
      auto c = open();
      if (!c) return std::string("cannot connect");
      if (auto e = want_error(c->request(protocol::Ping{}), ErrorCode::kHelloRequired);
          !e.empty()) {
        return "Ping: " + e;
      }
      if (auto e = want_error(c->request(protocol::GetStatus{}), ErrorCode::kHelloRequired);
          !e.empty()) {
        return "GetStatus: " + e;
      }
      if (auto e = want_error(c->request(protocol::MeasureDoorWidth{}), ErrorCode::kHelloRequired);
          !e.empty()) {
        return "MeasureDoorWidth: " + e;
      }
      const Response w = c->hello(Role::kObserver);
      if (!w.get<protocol::Welcome>()) return "Hello after refusals: " + describe(w);
      return still_usable(*c);
    });
    check("session: Stop is accepted before Hello (safety)", [&] {
      auto c = open();
      if (!c) return std::string("cannot connect");
      return want<protocol::Ack>(c->request(protocol::Stop{}));
    });
    check("session: a second Hello gets ALREADY_GREETED", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      if (auto e = want_error(c->hello(Role::kObserver), ErrorCode::kAlreadyGreeted); !e.empty()) {
        return e;
      }
      return still_usable(*c);
    });
    check("session: Hello with version_major 2 gets UNSUPPORTED_VERSION", [&] {
      auto c = open();
      if (!c) return std::string("cannot connect");
      protocol::Hello hello;
      hello.version_major = 2;
      return want_error(c->request(hello), ErrorCode::kUnsupportedVersion, "version_major");
    });
    check("session: Welcome carries the granted role, limits and distinct session ids", [&] {
      auto a = open();
      auto b = open();
      if (!a || !b) return std::string("cannot connect");
      const Response ra = a->hello(Role::kObserver);
      const Response rb = b->hello(Role::kObserver);
      const auto* wa = ra.get<protocol::Welcome>();
      const auto* wb = rb.get<protocol::Welcome>();
      if (!wa || !wb) return std::string("no Welcome");
      if (wa->granted_role != Role::kObserver) return std::string("role not observer");
      if (wa->session_id == wb->session_id) return std::string("same session id twice");
      if (wa->version_major != protocol::kVersionMajor) return std::string("wrong major version");
      if (!(wa->min_door_width_m > 0 && wa->max_door_width_m > wa->min_door_width_m)) {
        return std::string("door width limits not sensible");
      }
      if (!(wa->deadman_timeout_s > 0)) return std::string("no deadman timeout");
      return std::string{};
    });
    check("session: Ping echoes client_time_ns with the request id", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      return still_usable(*c);
    });
  }

  void roles() {
    check("roles: observer commands get NOT_CONTROLLER; reads and Stop are allowed", [&] {
      auto ctl = greeted(Role::kController, true);
      auto obs = greeted(Role::kObserver);
      if (!ctl || !obs) return std::string("cannot connect");
      for (const protocol::Message& m :
           {protocol::Message{
                protocol::MeasureDoorWidth{base_point(1, 0.4, 0), base_point(1, -0.4, 0)}},
            protocol::Message{protocol::MeasureHandle{}}, protocol::Message{door_plane(0.1)},
            protocol::Message{protocol::SetContactPoint{}},
            protocol::Message{protocol::AlignBase{}}, protocol::Message{protocol::Engage{}},
            protocol::Message{protocol::Reset{true}}}) {
        if (auto e = want_error(obs->request(m), ErrorCode::kNotController); !e.empty()) {
          return std::string(protocol::to_string(protocol::type_of(m))) + ": " + e;
        }
      }
      if (auto e = want<protocol::Status>(obs->request(protocol::GetStatus{})); !e.empty())
        return e;
      if (auto e = want<protocol::Ack>(obs->request(protocol::Stop{})); !e.empty()) return e;
      return still_usable(*obs);
    });
    check("roles: a second controller without take_over gets CONTROLLER_BUSY, may then observe",
          [&] {
            auto ctl = greeted(Role::kController, true);
            auto other = open();
            if (!ctl || !other) return std::string("cannot connect");
            if (auto e = want_error(other->hello(Role::kController, false),
                                    ErrorCode::kControllerBusy, "take_over");
                !e.empty()) {
              return e;
            }
            const Response w = other->hello(Role::kObserver);
            if (!w.get<protocol::Welcome>()) return "Hello as observer after: " + describe(w);
            return std::string{};
          });
    check("roles: take_over demotes the old controller and announces control_changed", [&] {
      // Declared before the client: its callback may run until the client is destroyed.
      std::mutex m;
      std::condition_variable cv;
      bool seen = false;
      auto old_ctl = greeted(Role::kController, true);
      if (!old_ctl) return std::string("cannot connect");
      old_ctl->on_event([&](const protocol::Event& e) {
        if (e.kind == protocol::EventKind::kControlChanged) {
          std::lock_guard lock(m);
          seen = true;
          cv.notify_all();
        }
      });
      auto new_ctl = greeted(Role::kController, true);
      if (!new_ctl) return std::string("take-over refused");
      if (auto e = want_error(old_ctl->request(protocol::Reset{false}), ErrorCode::kNotController);
          !e.empty()) {
        return "old controller: " + e;
      }
      if (auto e = want<protocol::Ack>(new_ctl->request(protocol::Reset{false})); !e.empty()) {
        return "new controller: " + e;
      }
      std::unique_lock lock(m);
      const bool ok = cv.wait_for(lock, timeout(), [&] { return seen; });
      lock.unlock();
      old_ctl->on_event(nullptr);
      return ok ? std::string{} : std::string("no control_changed event");
    });
    check("roles: the controller leaving frees control", [&] {
      {
        auto ctl = greeted(Role::kController, true);
        if (!ctl) return std::string("cannot connect");
      }
      for (int i = 0; i < 500; ++i) {  // up to ~10 s for the daemon to notice
        auto c = open();
        if (!c) return std::string("cannot connect");
        const Response r = c->hello(Role::kController, false);
        if (r.ok()) return std::string{};
        std::this_thread::sleep_for(Milliseconds{20});
      }
      return std::string("control still held after the controller disconnected");
    });
  }

  void telemetry() {
    check("telemetry: Subscribe delivers Telemetry; negative rate gets RATE_LIMITED", [&] {
      std::atomic<int> count{0};  // before the client: its callback may run until it is gone
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      if (auto e = want_error(c->request(protocol::Subscribe{-1.0f}), ErrorCode::kRateLimited,
                              "telemetry_rate_hz");
          !e.empty()) {
        return e;
      }
      c->on_telemetry([&](const protocol::Telemetry&) { ++count; });
      if (auto e = want<protocol::Ack>(c->request(protocol::Subscribe{100.0f})); !e.empty())
        return e;
      const auto deadline = Clock::now() + timeout();
      while (count.load() < 3 && Clock::now() < deadline)
        std::this_thread::sleep_for(Milliseconds{10});
      if (count.load() < 3) return std::string("fewer than 3 Telemetry frames");
      if (auto e = want<protocol::Ack>(c->request(protocol::Subscribe{0.0f})); !e.empty()) return e;
      c->on_telemetry(nullptr);
      return std::string{};
    });
  }

  // ---- the procedure, with every refusal on the way ----
  void procedure() {
    auto c = greeted(Role::kController, true);
    if (!c) {
      check("procedure: take control", [] { return std::string("cannot take control"); });
      return;
    }
    c->set_heartbeat(Milliseconds{100});
    (void)c->request(protocol::Reset{true});
    auto refuse = [&](const std::string& name, const protocol::Message& m, ErrorCode code,
                      const char* field = nullptr) {
      const auto type = protocol::type_of(m);
      // A daemon that wrongly accepted one of these would move the base or the arm.
      const bool moves = type == MessageType::kAlignBase || type == MessageType::kEngage;
      std::invoke(moves ? &Suite::moving : &Suite::check, this,
                  "procedure: " + name + " -> " + std::string(ajar::to_string(code)), [&] {
                    const auto before = status(*c);
                    if (auto e = want_error(c->request(m), code, field); !e.empty()) return e;
                    const auto after = status(*c);
                    if (!before || !after || before->state != after->state) {
                      return std::string("the refusal changed the state");
                    }
                    return std::string{};
                  });
    };
    const protocol::SetContactPoint reachable{base_point(0.8, 0.0, 0.3)};
    // Nothing measured yet.
    refuse("MeasureHandle first",
           protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)},
           ErrorCode::kMissingDoorWidth);
    refuse("MeasureDoorPlane first", door_plane(0.05), ErrorCode::kMissingDoorWidth);
    refuse("SetContactPoint first", reachable, ErrorCode::kMissingDoorWidth);
    refuse("AlignBase first", protocol::AlignBase{}, ErrorCode::kMissingDoorWidth);
    refuse("Engage first", protocol::Engage{}, ErrorCode::kMissingDoorWidth);
    // Door width validation.
    refuse("width point too near the camera",
           protocol::MeasureDoorWidth{framed(core::Frame::kCamera, -0.4, 0, 0.1),
                                      framed(core::Frame::kCamera, 0.4, 0, 1.0)},
           ErrorCode::kPointOutOfDepthRange);
    refuse("width with P1 = P2",
           protocol::MeasureDoorWidth{base_point(1, 0.2, 0.3), base_point(1, 0.2, 0.3)},
           ErrorCode::kPointsTooClose);
    refuse("width with y1 = y2",
           protocol::MeasureDoorWidth{base_point(1, 0.2, 0.0), base_point(1, 0.2, 0.8)},
           ErrorCode::kAmbiguousDirection);
    refuse("width mostly in height",
           protocol::MeasureDoorWidth{base_point(1, 0.2, 0.0), base_point(1, 0.1, 0.9)},
           ErrorCode::kPointsNotSideBySide);
    refuse("width of 3 m",
           protocol::MeasureDoorWidth{base_point(1.5, 1.5, 0.3), base_point(1.5, -1.5, 0.3)},
           ErrorCode::kWidthOutOfRange, "width_m");
    check("procedure: Algorithm 1 answers CW when y1 < y2", [&] {
      const Response r = c->request(
          protocol::MeasureDoorWidth{base_point(1, -0.45, 0.3), base_point(1, 0.45, 0.3)});
      const auto* ack = r.get<protocol::Ack>();
      const auto* span = ack ? std::get_if<protocol::SpanAck>(&ack->body) : nullptr;
      if (!span) return "got " + describe(r);
      if (span->direction != core::RotationDirection::kClockwise) return std::string("not CW");
      return std::string{};
    });
    check("procedure: door width 0.9 m CCW, points echoed in the base frame", [&] {
      const Response r = c->request(
          protocol::MeasureDoorWidth{base_point(1, 0.45, 0.3), base_point(1, -0.45, 0.3)});
      if (auto e = want_ack(r, ProcedureState::kAwaitingHandle); !e.empty()) return e;
      const auto* span = std::get_if<protocol::SpanAck>(&r.get<protocol::Ack>()->body);
      if (!span) return std::string("Ack without a span body");
      if (!near(span->length_m, 0.9, 1e-9)) return "width " + json_number(span->length_m);
      if (span->direction != core::RotationDirection::kCounterClockwise)
        return std::string("not CCW");
      if (!span->p1_base_m.isApprox(core::Vec3(1, 0.45, 0.3), 1e-9)) return std::string("p1 moved");
      return std::string{};
    });
    refuse("MeasureDoorPlane before the handle", door_plane(0.05), ErrorCode::kMissingHandle);
    refuse("AlignBase before the handle", protocol::AlignBase{}, ErrorCode::kMissingHandle);
    refuse("handle of 0.5 m",
           protocol::MeasureHandle{base_point(0.95, -0.3, 0.3), base_point(0.95, 0.2, 0.3)},
           ErrorCode::kHandleLengthOutOfRange, "handle_length_m");
    check("procedure: handle 0.12 m", [&] {
      const Response r = c->request(
          protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)});
      if (auto e = want_ack(r, ProcedureState::kAwaitingPlane); !e.empty()) return e;
      const auto* span = std::get_if<protocol::SpanAck>(&r.get<protocol::Ack>()->body);
      if (!span || !near(span->length_m, 0.12, 1e-9)) return std::string("wrong handle length");
      return std::string{};
    });
    refuse("AlignBase before the plane", protocol::AlignBase{}, ErrorCode::kMissingPlane);
    refuse("SetContactPoint before the plane", reachable, ErrorCode::kMissingPlane);
    // Plane validation.
    refuse("collinear plane points",
           plane_of({base_point(1, -0.3, 0.3), base_point(1, 0, 0.3), base_point(1, 0.3, 0.3)}),
           ErrorCode::kPointsCollinear);
    refuse("duplicate plane points",
           plane_of({base_point(1, -0.3, 0.0), base_point(1, -0.3, 0.0), base_point(1, 0.3, 0.5)}),
           ErrorCode::kPointsTooClose);
    refuse("horizontal plane",
           plane_of(
               {base_point(1, -0.3, -0.5), base_point(1.6, 0.3, -0.5), base_point(2, -0.2, -0.5)}),
           ErrorCode::kPlaneNotVertical);
    refuse("yaw of 1.0 rad", door_plane(1.0, 1.5), ErrorCode::kYawOutOfRange, "yaw_deviation_rad");
    refuse("bumpy plane (rms > limit)",
           plane_of({door_point(1, 0, -0.3, 0.0, 0.1), door_point(1, 0, 0.3, 0.0, -0.1),
                     door_point(1, 0, 0.3, 0.7, 0.1), door_point(1, 0, -0.3, 0.7, -0.1)}),
           ErrorCode::kPlaneResidualTooLarge, "rms_residual_m");
    check("procedure: plane turned +0.05 rad: signed yaw, wheels opposite", [&] {
      const Response r = c->request(door_plane(0.05));
      if (auto e = want_ack(r, ProcedureState::kReadyToAlign); !e.empty()) return e;
      const auto* p = std::get_if<protocol::PlaneAck>(&r.get<protocol::Ack>()->body);
      if (!p) return std::string("Ack without a plane body");
      if (!near(p->yaw_deviation_rad, 0.05, 1e-6))
        return "yaw " + json_number(p->yaw_deviation_rad);
      if (!(p->left_wheel_rad < 0 && p->right_wheel_rad > 0)) {
        return std::string("CCW turn needs left wheel back, right wheel forward");
      }
      if (!(p->normal.x() < 0)) return std::string("normal not toward the robot");
      if (p->point_count != 4) return std::string("point_count not 4");
      return std::string{};
    });
    refuse("SetContactPoint before aligning", reachable, ErrorCode::kNotAligned);
    refuse("Engage before aligning", protocol::Engage{}, ErrorCode::kNotAligned);
    if (!motion_refused_.empty()) {  // the rest turns the base and engages the arm
      check("procedure: align, contact point, engage", [&] { return skip(motion_refused_); });
      return;
    }
    check("procedure: AlignBase accepted; a command during the motion gets MOTION_IN_PROGRESS",
          [&] {
            const auto before = status(*c);
            if (!before) return std::string("no status");
            yaw_before_align_ = before->base_yaw_odometry_rad;
            const std::uint32_t align_id = c->next_request_id();
            const std::uint32_t plane_id = c->next_request_id();
            // Pipelined: the second frame is handled while the base turns.
            c->send_envelope(protocol::Envelope{align_id, 0, protocol::AlignBase{}});
            c->send_envelope(protocol::Envelope{plane_id, 0, door_plane(0.05)});
            auto ack = c->wait_reply(align_id, timeout());
            auto busy = c->wait_reply(plane_id, timeout());
            const auto* a = ack ? std::get_if<protocol::Ack>(&ack->message) : nullptr;
            if (!a || a->state != ProcedureState::kAligning) return "AlignBase: " + describe(ack);
            return want_error(busy, ErrorCode::kMotionInProgress);
          });
    check("procedure: the alignment finishes in state aligned; odometry turned +0.05 rad", [&] {
      const auto s = wait_not(*c, ProcedureState::kAligning, 60);
      if (!s) return std::string("still aligning after 60 s");
      if (s->state != ProcedureState::kAligned) {
        return "ended in " + std::string(protocol::to_string(s->state)) + ", fault " +
               std::string(ajar::to_string(s->latched_fault));
      }
      const double turned =
          std::remainder(s->base_yaw_odometry_rad - yaw_before_align_, 2 * std::numbers::pi);
      if (!near(turned, 0.05, 0.005)) return "odometry turned " + json_number(turned) + " rad";
      return std::string{};
    });
    refuse("AlignBase when aligned", protocol::AlignBase{}, ErrorCode::kWrongState);
    refuse("Engage without a contact point", protocol::Engage{}, ErrorCode::kMissingContactPoint);
    refuse("contact point 3 m away", protocol::SetContactPoint{base_point(3.0, 0, 0.3)},
           ErrorCode::kOutOfReach, "contact");
    check("procedure: contact point accepted in the base frame", [&] {
      const Response r = c->request(reachable);
      if (auto e = want_ack(r, ProcedureState::kReadyToEngage); !e.empty()) return e;
      const auto* ct = std::get_if<protocol::ContactAck>(&r.get<protocol::Ack>()->body);
      if (!ct || !ct->contact_base_m.isApprox(reachable.contact.position_m, 1e-9)) {
        return std::string("contact point not echoed");
      }
      if (!(ct->reach_margin_m >= 0)) return std::string("negative reach margin");
      return std::string{};
    });
    check("procedure: Engage hands over to the arm and ends engaged", [&] {
      const Response r = c->request(protocol::Engage{});
      const auto* ack = r.get<protocol::Ack>();
      if (!ack ||
          (ack->state != ProcedureState::kEngaging && ack->state != ProcedureState::kEngaged)) {
        return "expected Ack (engaging), got " + describe(r);
      }
      const auto s = wait_not(*c, ProcedureState::kEngaging, 60);
      if (!s || s->state != ProcedureState::kEngaged) {
        return std::string("did not reach engaged");
      }
      return std::string{};
    });
  }

  // ---- protocol 1.1: versions, the robot model, loop statistics ----
  // Says Hello 1.0 (header and payload minor 0) on `c` as an observer; "" when welcomed.
  std::string hello_1_0(Client& c) {
    protocol::Hello hello;
    hello.version_minor = 0;
    hello.requested_role = Role::kObserver;
    hello.client_instance_id = c.client_instance_id();
    hello.client_name = "ajarctl conformance 1.0";
    const std::uint32_t id = c.next_request_id();
    auto welcome = raw(c, frame_bytes(protocol::Envelope{id, 0, hello}, 0), id);
    if (!welcome || !std::holds_alternative<protocol::Welcome>(welcome->message)) {
      return "Hello 1.0: " + describe(welcome);
    }
    return {};
  }

  void protocol_1_1() {
    check("1.1: Welcome says minor 1 and a defined driver_kind", [&] {
      auto c = open();
      if (!c) return std::string("cannot connect");
      const Response r = c->hello(Role::kObserver);
      const auto* w = r.get<protocol::Welcome>();
      if (!w) return "Hello: " + describe(r);
      if (w->version_minor < 1) {
        return "Welcome.version_minor is " + std::to_string(w->version_minor) + ": a 1.0 daemon";
      }
      const auto kind = static_cast<unsigned>(w->driver_kind);
      if (kind > static_cast<unsigned>(protocol::DriverKind::kReal)) {
        return "driver_kind " + std::to_string(kind) + " is not defined";
      }
      return std::string{};
    });
    check(
        "1.1: a 1.0 session gets 1.0 frames (header minor 0; Welcome 72, Status 285, "
        "Telemetry 87 bytes)",
        [&] {
          std::atomic<int> telemetry{0};  // before the client: its callback may run until then
          auto c = open();
          if (!c) return std::string("cannot connect");
          c->on_telemetry([&](const protocol::Telemetry&) { ++telemetry; });
          c->record_headers(true);
          if (auto e = hello_1_0(*c); !e.empty()) return e;
          const std::uint32_t sub = c->next_request_id();
          auto ack =
              raw(*c, frame_bytes(protocol::Envelope{sub, 0, protocol::Subscribe{50.0f}}, 0), sub);
          if (!ack || !std::holds_alternative<protocol::Ack>(ack->message)) {
            return "Subscribe: " + describe(ack);
          }
          const auto deadline = Clock::now() + timeout();
          while (telemetry.load() < 2 && Clock::now() < deadline)
            std::this_thread::sleep_for(Milliseconds{10});
          const std::uint32_t get = c->next_request_id();
          auto st = raw(*c, frame_bytes(protocol::Envelope{get, 0, protocol::GetStatus{}}, 0), get);
          const std::uint32_t off = c->next_request_id();
          (void)raw(*c, frame_bytes(protocol::Envelope{off, 0, protocol::Subscribe{0.0f}}, 0), off);
          c->on_telemetry(nullptr);
          const auto headers = c->recorded_headers();
          c->record_headers(false);
          const std::map<MessageType, std::uint32_t> layout{{MessageType::kWelcome, 72},
                                                            {MessageType::kStatus, 285},
                                                            {MessageType::kTelemetry, 87}};
          std::set<MessageType> seen;
          for (const auto& h : headers) {
            const auto type = static_cast<MessageType>(h.type);
            const std::string name(protocol::to_string(type));
            if (h.version_minor != 0) {
              return name + " frame says minor " + std::to_string(h.version_minor) +
                     " in a 1.0 session";
            }
            if (auto it = layout.find(type); it != layout.end()) {
              if (h.payload_length != it->second) {
                return name + " has " + std::to_string(h.payload_length) + " bytes; 1.0 has " +
                       std::to_string(it->second);
              }
              seen.insert(type);
            }
          }
          if (!st || !std::holds_alternative<protocol::Status>(st->message)) {
            return "GetStatus: " + describe(st);
          }
          if (seen.size() != layout.size()) {
            return "saw " + std::to_string(seen.size()) +
                   " of Welcome, Status, Telemetry (Telemetry frames decoded: " +
                   std::to_string(telemetry.load()) + ")";
          }
          return std::string{};
        });
    check(
        "1.1: in a 1.0 session Drive, Approach, GetRobotModel, ResetLoopStatistics are "
        "UNKNOWN_MESSAGE_TYPE (header.type), in 1.0 and in 1.1 frames",
        [&] {
          auto c = open();
          if (!c) return std::string("cannot connect");
          if (auto e = hello_1_0(*c); !e.empty()) return e;
          for (const protocol::Message& m : {protocol::Message{protocol::Drive{0.05, 0}},
                                             protocol::Message{protocol::Approach{1.0}},
                                             protocol::Message{protocol::GetRobotModel{}},
                                             protocol::Message{protocol::ResetLoopStatistics{}}}) {
            for (const int minor : {1, 0}) {
              const std::uint32_t id = c->next_request_id();
              auto f = frame_bytes(protocol::Envelope{id, 0, m});
              if (minor == 0) {
                f[5] = 0;
                fix_crc(f);
              }
              if (auto e =
                      want_error(raw(*c, f, id), ErrorCode::kUnknownMessageType, "header.type", id);
                  !e.empty()) {
                return std::string(protocol::to_string(protocol::type_of(m))) + " in a 1." +
                       std::to_string(minor) + " frame: " + e;
              }
            }
          }
          return still_usable(*c);
        });
    check(
        "1.1: GetRobotModel answers a plausible RobotModel (rigid camera_to_base, the Welcome's "
        "limits)",
        [&] {
          auto c = open();
          if (!c) return std::string("cannot connect");
          const Response h = c->hello(Role::kObserver);
          const auto* w = h.get<protocol::Welcome>();
          if (!w) return "Hello: " + describe(h);
          const Response r = c->request(protocol::GetRobotModel{});
          const auto* m = r.get<protocol::RobotModel>();
          if (!m) return "GetRobotModel: " + describe(r);
          model_ = *m;
          return robot_model_problems(*m, *w);
        });
    check("1.1: ResetLoopStatistics needs the controller role and restarts the statistics", [&] {
      auto obs = greeted(Role::kObserver);
      auto ctl = greeted(Role::kController, true);
      if (!obs || !ctl) return std::string("cannot connect");
      if (auto e =
              want_error(obs->request(protocol::ResetLoopStatistics{}), ErrorCode::kNotController);
          !e.empty()) {
        return "observer: " + e;
      }
      const auto before = status(*ctl);
      const Response r = ctl->request(protocol::ResetLoopStatistics{});
      const auto* ack = r.get<protocol::Ack>();
      if (!ack || ack->acknowledged != MessageType::kResetLoopStatistics) {
        return "controller: expected Ack of ResetLoopStatistics, got " + describe(r);
      }
      const auto after = status(*ctl);
      if (!before || !after) return std::string("no status");
      if (before->timing.all.samples > 100 &&
          !(after->timing.all.samples < before->timing.all.samples)) {
        return "timing.all.samples went from " + std::to_string(before->timing.all.samples) +
               " to " + std::to_string(after->timing.all.samples) + ": not restarted";
      }
      return std::string{};
    });
    check("1.1: Drive with a NaN / infinite velocity is NON_FINITE_NUMBER naming the field", [&] {
      auto c = greeted(Role::kObserver);
      if (!c) return std::string("cannot connect");
      const std::pair<const char*, std::uint64_t> cases[] = {
          {"linear_m_s", 0x7ff8000000000000ull}, {"angular_rad_s", 0x7ff0000000000000ull}};
      std::size_t offset = 0;
      for (const auto& [field, bits] : cases) {
        const std::uint32_t id = c->next_request_id();
        auto f = frame_bytes(protocol::Envelope{id, 0, protocol::Drive{0.05, 0.1}});
        put_f64(f, protocol::kHeaderSize + offset, bits);
        offset += 8;
        fix_crc(f);
        const auto reply = raw(*c, f, id);
        if (auto e = want_error(reply, ErrorCode::kNonFiniteNumber, field, id); !e.empty())
          return e;
        const auto& message = std::get<protocol::ErrorReply>(reply->message).message;
        if (message.view().find(field) == std::string_view::npos) {
          return "the sentence does not name " + std::string(field) + ": '" +
                 std::string(message.view()) + "'";
        }
      }
      return still_usable(*c);
    });
  }

  // "" when the model is plausible, else what is not.
  static std::string robot_model_problems(const protocol::RobotModel& m,
                                          const protocol::Welcome& w) {
    std::string wrong;
    auto need = [&](bool ok, const std::string& what) {
      if (!ok) wrong += (wrong.empty() ? "" : "; ") + what;
    };
    need(m.wheel_radius_m > 0 && m.wheel_radius_m <= 1,
         "wheel_radius_m " + json_number(m.wheel_radius_m) + " not in (0, 1]");
    need(m.turning_radius_m > 0 && m.turning_radius_m <= 5,
         "turning_radius_m " + json_number(m.turning_radius_m) + " not in (0, 5]");
    need(m.encoder_counts_per_rev >= 1, "encoder_counts_per_rev below 1");
    need(m.gear_ratio > 0, "gear_ratio not positive");
    need(m.left.card_axis >= 1 && m.right.card_axis >= 1 && m.left.card_axis != m.right.card_axis,
         "wheel card axes not distinct axes from 1");
    Eigen::Matrix3d rotation;
    Eigen::Vector3d translation;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c)
        rotation(r, c) = m.camera_to_base[static_cast<std::size_t>(r * 4 + c)];
      translation(r) = m.camera_to_base[static_cast<std::size_t>(r * 4 + 3)];
    }
    const double orthogonality =
        (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    need(orthogonality < 1e-6 && std::abs(rotation.determinant() - 1) < 1e-6,
         "camera_to_base is not rigid (|R Rt - I| = " + json_number(orthogonality) +
             ", det R = " + json_number(rotation.determinant()) + ")");
    need(translation.norm() < 5, "camera_to_base translation above 5 m");
    need(m.min_door_width_m < m.max_door_width_m, "door width range empty");
    need(m.min_handle_length_m < m.max_handle_length_m, "handle length range empty");
    need(m.min_depth_m < m.max_depth_m, "depth range empty");
    need(m.arm_min_reach_m < m.arm_max_reach_m && m.arm_min_z_m < m.arm_max_z_m,
         "arm workspace empty");
    for (const double v :
         {m.max_linear_speed_m_s, m.max_angular_speed_rad_s, m.max_linear_accel_m_s2,
          m.max_angular_accel_rad_s2, m.drive_command_timeout_s, m.approach_max_travel_m,
          m.approach_square_tolerance_rad, m.approach_min_standoff_m, m.stale_travel_m,
          m.stale_yaw_rad, m.max_wheel_speed_rad_s, m.max_wheel_accel_rad_s2}) {
      need(v >= 0, "a drive/approach/staleness limit is negative (" + json_number(v) + ")");
    }
    // The Welcome's f32 limits are the model's, rounded to f32.
    const std::pair<const char*, std::pair<double, float>> same[] = {
        {"min_door_width_m", {m.min_door_width_m, w.min_door_width_m}},
        {"max_door_width_m", {m.max_door_width_m, w.max_door_width_m}},
        {"min_handle_length_m", {m.min_handle_length_m, w.min_handle_length_m}},
        {"max_handle_length_m", {m.max_handle_length_m, w.max_handle_length_m}},
        {"max_yaw_correction_rad", {m.max_yaw_correction_rad, w.max_yaw_correction_rad}}};
    for (const auto& [name, values] : same) {
      need(static_cast<float>(values.first) == values.second,
           std::string(name) + " differs from the Welcome's");
    }
    return wrong;
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

  void driving() {
    check("drive: an observer's Drive gets NOT_CONTROLLER", [&] {
      auto obs = greeted(Role::kObserver);
      if (!obs) return std::string("cannot connect");
      const Response r = obs->request(protocol::Drive{0.05, 0});
      if (auto s = not_supported(r); !s.empty()) return s;
      return want_error(r, ErrorCode::kNotController);
    });
    // Everything below is sent by the controller: a daemon that wrongly accepted it would move the
    // base, so it runs only where motion is allowed.
    std::unique_ptr<Client> c;
    if (motion_refused_.empty()) {
      c = greeted(Role::kController, true);
      if (c) {
        c->set_heartbeat(Milliseconds{100});
        (void)c->request(protocol::Reset{true});
      }
    }
    auto controller = [&](const std::string& name,
                          const std::function<std::string(Client&)>& body) {
      moving(name, [&] { return c ? body(*c) : std::string("cannot take control"); });
    };
    const double min_standoff_m = model_ ? model_->approach_min_standoff_m : 0.0;
    const double timeout_s = model_ ? model_->drive_command_timeout_s : 0.0;
    auto measure_width_at = [&](Client& k, double x_m) {
      return want_ack(k.request(protocol::MeasureDoorWidth{base_point(x_m, 0.45, 0.3),
                                                           base_point(x_m, -0.45, 0.3)}),
                      ProcedureState::kAwaitingHandle);
    };
    controller("approach: with nothing measured -> NO_DOOR_DISTANCE", [&](Client& k) {
      (void)k.request(protocol::Reset{true});
      const Response r = k.request(protocol::Approach{1.0});
      if (auto s = not_supported(r); !s.empty()) return s;
      return want_error(r, ErrorCode::kNoDoorDistance);
    });
    controller(
        "approach: standoff below approach_min_standoff_m -> STANDOFF_OUT_OF_RANGE "
        "(standoff_m)",
        [&](Client& k) {
          if (auto e = measure_width_at(k, 1.2); !e.empty()) return "width: " + e;
          const Response r = k.request(protocol::Approach{min_standoff_m - 0.05});
          if (auto s = not_supported(r); !s.empty()) return s;
          return want_error(r, ErrorCode::kStandoffOutOfRange, "standoff_m");
        });
    controller(
        "drive: Drive is accepted, Telemetry shows the commanded velocity (within the limit), the "
        "base moves forward; Drive{0, 0} brings it to rest",
        [&](Client& k) {
          auto tm = watch_telemetry(k);
          if (auto e = want<protocol::Ack>(k.request(protocol::Subscribe{50.0f})); !e.empty())
            return "Subscribe: " + e;
          const auto before = status(k);
          const double speed = 0.05;
          const auto period = teleop::resend_period(timeout_s);
          const auto end = Clock::now() + Milliseconds{600};
          while (Clock::now() < end) {
            const Response r = k.request(protocol::Drive{speed, 0});
            if (auto s = not_supported(r); !s.empty()) {
              k.on_telemetry(nullptr);
              return s;
            }
            if (!r.ok()) return "Drive: " + describe(r);
            std::this_thread::sleep_for(period);
          }
          std::uint64_t count = 0;
          {
            std::lock_guard lock(tm->mutex);
            count = tm->count;
          }
          if (auto e = want<protocol::Ack>(k.request(protocol::Drive{0, 0})); !e.empty())
            return "Drive{0, 0}: " + e;
          const bool rest = wait_at_rest(*tm, count, 10);
          (void)k.request(protocol::Subscribe{0.0f});
          k.on_telemetry(nullptr);
          const auto after = status(k);
          if (!rest) return std::string("not at rest 10 s after Drive{0, 0}");
          if (!before || !after) return std::string("no status");
          double max_commanded = 0;
          {
            std::lock_guard lock(tm->mutex);
            max_commanded = tm->max_commanded_linear_m_s;
          }
          if (!(max_commanded > 0))
            return std::string("Telemetry never showed a commanded velocity");
          if (max_commanded > speed + 1e-9) {
            return "commanded " + json_number(max_commanded) + " m/s, more than the " +
                   json_number(speed) + " m/s asked";
          }
          const double moved = after->odometry_x_m - before->odometry_x_m;
          if (!(moved > 0.002)) return "odometry x moved " + json_number(moved) + " m";
          return std::string{};
        });
    controller(
        "drive: a Drive that is not re-sent stops after drive_command_timeout_s", [&](Client& k) {
          auto tm = watch_telemetry(k);
          if (auto e = want<protocol::Ack>(k.request(protocol::Subscribe{50.0f})); !e.empty())
            return "Subscribe: " + e;
          const Response r = k.request(protocol::Drive{0.05, 0});
          if (auto s = not_supported(r); !s.empty()) {
            k.on_telemetry(nullptr);
            return s;
          }
          if (!r.ok()) return "Drive: " + describe(r);
          // Only heartbeat Pings from here on: the timeout alone must stop the base.
          const bool rest = wait_at_rest(*tm, 0, std::max(timeout_s, 0.5) + 10);
          (void)k.request(protocol::Subscribe{0.0f});
          k.on_telemetry(nullptr);
          if (!rest) {
            (void)k.request(protocol::Stop{});
            return "still moving " + json_number(std::max(timeout_s, 0.5) + 10) +
                   " s after the only Drive (Stop sent)";
          }
          return std::string{};
        });
    controller(
        "approach: from 1.2 m to the standoff: ApproachBody (travel, start distance, counts), "
        "motion_finished, then the door distance is the standoff",
        [&](Client& k) {
          (void)k.request(protocol::Reset{true});
          if (auto e = measure_width_at(k, 1.2); !e.empty()) return "width: " + e;
          const auto before = status(k);
          if (!before || !before->door.has_distance) {
            // A daemon that does not drive yet has no distance either: say so rather than fail.
            if (auto s = not_supported(k.request(protocol::Approach{1.0})); !s.empty()) return s;
            return std::string("Status has no door distance after the width was measured");
          }
          const double start = before->door.distance_m;
          double standoff = std::max(min_standoff_m, 1.0);
          if (model_ && model_->approach_max_travel_m > 0 &&
              start - standoff > model_->approach_max_travel_m) {
            standoff = start - model_->approach_max_travel_m / 2;
          }
          auto events = std::make_shared<EventWatch>();
          k.on_event([events](const protocol::Event& e) {
            std::lock_guard lock(events->mutex);
            events->kinds.push_back(e.kind);
          });
          const Response r = k.request(protocol::Approach{standoff});
          if (auto s = not_supported(r); !s.empty()) {
            k.on_event(nullptr);
            return s;
          }
          const auto* ack = r.get<protocol::Ack>();
          const auto* body = ack ? std::get_if<protocol::ApproachAck>(&ack->body) : nullptr;
          if (!body) {
            k.on_event(nullptr);
            return "expected Ack with an ApproachBody, got " + describe(r);
          }
          std::string wrong;
          if (!near(body->start_distance_m, start, 1e-3)) {
            wrong = "start_distance_m " + json_number(body->start_distance_m) + ", Status said " +
                    json_number(start);
          } else if (!near(body->travel_m, body->start_distance_m - standoff, 1e-9)) {
            wrong = "travel_m " + json_number(body->travel_m) + " is not start - standoff";
          } else if (model_) {
            const double counts = body->travel_m / model_->wheel_radius_m / (2 * std::numbers::pi) *
                                  model_->gear_ratio * model_->encoder_counts_per_rev;
            const double left = static_cast<double>(body->left_counts) * model_->left.polarity;
            const double right = static_cast<double>(body->right_counts) * model_->right.polarity;
            if (!near(left, counts, 1.0) || !near(right, counts, 1.0)) {
              wrong = "wheel counts " + std::to_string(body->left_counts) + " / " +
                      std::to_string(body->right_counts) + " (card), expected " +
                      json_number(counts) + " motor counts x polarity";
            }
          }
          // Wait for the end of the move, feeding the deadman.
          std::optional<protocol::EventKind> end;
          const auto deadline = Clock::now() + Milliseconds{60000};
          while (!end && Clock::now() < deadline) {
            {
              std::lock_guard lock(events->mutex);
              for (const auto kind : events->kinds) {
                if (kind == protocol::EventKind::kMotionFinished ||
                    kind == protocol::EventKind::kMotionStopped ||
                    kind == protocol::EventKind::kFaultLatched) {
                  end = kind;
                }
              }
            }
            std::this_thread::sleep_for(Milliseconds{20});
          }
          k.on_event(nullptr);
          if (!wrong.empty()) return wrong;
          if (!end) return std::string("no motion_finished within 60 s");
          if (*end != protocol::EventKind::kMotionFinished) {
            return "the approach ended with " + std::string(protocol::to_string(*end));
          }
          const auto after = status(k);
          if (!after || !after->door.has_distance) return std::string("no door distance after");
          if (!near(after->door.distance_m, standoff, 0.01)) {
            return "door distance " + json_number(after->door.distance_m) + " m, standoff " +
                   json_number(standoff) + " m";
          }
          return std::string{};
        });
    if (c) {
      (void)c->request(protocol::Stop{});
      (void)c->request(protocol::Reset{true});
    }
  }

  // ---- exactly-once execution ----
  void duplicates() {
    check("duplicates: a repeated request id is answered identically and not executed again", [&] {
      auto c = greeted(Role::kController, true);
      if (!c) return std::string("cannot connect");
      const protocol::MeasureDoorWidth first{base_point(1, 0.45, 0.3), base_point(1, -0.45, 0.3)};
      const protocol::MeasureDoorWidth second{base_point(1, 0.40, 0.3), base_point(1, -0.40, 0.3)};
      const std::uint32_t id1 = c->next_request_id();
      const std::uint32_t id2 = c->next_request_id();
      c->send_envelope(protocol::Envelope{id1, 0, first});
      auto r1 = c->wait_reply(id1, timeout());
      c->send_envelope(protocol::Envelope{id2, 0, second});
      auto r2 = c->wait_reply(id2, timeout());
      if (!r1 || !r2) return std::string("no replies");
      c->send_envelope(protocol::Envelope{id1, protocol::kFlagRetransmit, first});
      auto again = c->wait_reply(id1, timeout());
      if (!again || !protocol::wire_equal(again->message, r1->message)) {
        return "repeat answered differently: " + describe(again);
      }
      auto s = status(*c);
      if (!s || !s->has_width || !near(s->width.length_m, 0.8, 1e-9)) {
        return std::string("the repeat was executed again (stored width is not the second one)");
      }
      // Over a new connection of the same client instance.
      c->close();
      if (!c->connect(options_.endpoint).empty()) return std::string("cannot reconnect");
      if (!c->hello(Role::kController, true).ok()) return std::string("Hello after reconnect");
      c->send_envelope(protocol::Envelope{id1, protocol::kFlagRetransmit, first});
      auto after = c->wait_reply(id1, timeout());
      if (!after || !protocol::wire_equal(after->message, r1->message)) {
        return "repeat after reconnect answered differently: " + describe(after);
      }
      s = status(*c);
      if (!s || !near(s->width.length_m, 0.8, 1e-9)) {
        return std::string("the repeat after reconnect was executed again");
      }
      return std::string{};
    });
  }

  // ---- latched faults ----
  void faults() {
    check(
        "faults: EmergencyStop latches EMERGENCY_STOPPED; commands get FAULT_LATCHED; Reset clears",
        [&] {
          auto c = greeted(Role::kController, true);
          if (!c) return std::string("cannot connect");
          if (auto e = want<protocol::Ack>(c->request(protocol::EmergencyStop{})); !e.empty()) {
            return e;
          }
          auto s = status(*c);
          if (!s || s->state != ProcedureState::kFault ||
              s->latched_fault != ErrorCode::kEmergencyStopped) {
            return std::string("no EMERGENCY_STOPPED fault latched");
          }
          if (auto e = want_error(c->request(protocol::MeasureDoorWidth{base_point(1, 0.45, 0.3),
                                                                        base_point(1, -0.45, 0.3)}),
                                  ErrorCode::kFaultLatched);
              !e.empty()) {
            return e;
          }
          if (auto e = want<protocol::Ack>(c->request(protocol::Reset{false})); !e.empty())
            return e;
          s = status(*c);
          if (!s || s->latched_fault != ErrorCode::kOk || s->state == ProcedureState::kFault) {
            return std::string("Reset did not clear the fault");
          }
          return std::string{};
        });
    moving("faults: the controller leaving during motion stops it and latches DEADMAN", [&] {
      auto watcher = greeted(Role::kObserver);
      {
        auto c = greeted(Role::kController, true);
        if (!c || !watcher) return std::string("cannot connect");
        (void)c->request(protocol::Reset{true});
        (void)c->request(
            protocol::MeasureDoorWidth{base_point(1, 0.45, 0.3), base_point(1, -0.45, 0.3)});
        (void)c->request(
            protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)});
        if (auto e = want_ack(c->request(door_plane(0.6, 1.5)), ProcedureState::kReadyToAlign);
            !e.empty()) {
          return "plane: " + e;
        }
        c->send_envelope(protocol::Envelope{c->next_request_id(), 0, protocol::AlignBase{}});
        c->close();  // gone mid-motion
      }
      const auto deadline = Clock::now() + Milliseconds{5000};
      while (Clock::now() < deadline) {
        const auto s = status(*watcher);
        if (!s) return std::string("observer lost");
        if (s->latched_fault == ErrorCode::kDeadman) return std::string{};
        if (s->state == ProcedureState::kAligned) {
          return std::string(
              "the motion finished before the disconnect was noticed (sim too fast?)");
        }
        std::this_thread::sleep_for(Milliseconds{20});
      }
      return std::string("no DEADMAN latched");
    });
    clean("faults: Reset after DEADMAN");
  }

  // ---- garbage must not hurt other sessions ----
  void garbage() {
    check("garbage: an observer keeps getting replies while other sessions send garbage", [&] {
      auto observer = greeted(Role::kObserver);
      if (!observer) return std::string("cannot connect");
      std::atomic<bool> done{false};
      std::atomic<int> answered{0}, unanswered{0};
      std::thread pinger([&] {
        while (!done.load()) {
          if (observer->request(protocol::Ping{1}).get<protocol::Pong>()) {
            ++answered;
          } else {
            ++unanswered;
          }
        }
      });
      std::mt19937 rng(12345);
      std::uniform_int_distribution<int> byte(0, 255);
      std::string why;
      for (int round = 0; round < 12 && why.empty(); ++round) {
        auto g = open();
        if (!g) {
          why = "a new connection was refused during garbage";
          break;
        }
        std::vector<std::uint8_t> junk(200 + static_cast<std::size_t>(round) * 50);
        for (auto& b : junk)
          b = static_cast<std::uint8_t>(byte(rng));
        switch (round % 4) {
          case 0:  // random bytes: bad magic, closed
            junk[0] = 'X';
            g->send_raw(junk);
            if (!g->wait_closed(timeout())) why = "random bytes did not close the connection";
            break;
          case 1: {  // a burst of CRC-damaged frames, then a good Ping on the same session
            (void)g->hello(Role::kObserver);
            for (int i = 0; i < 50; ++i) {
              auto f = frame_bytes(
                  protocol::Envelope{static_cast<std::uint32_t>(100 + i), 0, protocol::Ping{}});
              f[f.size() - 1] ^= 0xFF;
              g->send_raw(f);
            }
            if (!still_usable(*g).empty()) why = "session unusable after CRC-damaged frames";
            break;
          }
          case 2: {  // a valid header announcing a huge payload
            auto f = frame_bytes(protocol::Envelope{7, 0, protocol::Ping{}});
            put_u32(f, 14, 0xFFFFFFFFu);
            g->send_raw(f);
            if (!g->wait_closed(timeout())) why = "an oversize header did not close the connection";
            break;
          }
          case 3: {  // half a frame, then hang up
            auto f = frame_bytes(protocol::Envelope{7, 0, protocol::Ping{}});
            f.resize(f.size() / 2);
            g->send_raw(f);
            std::this_thread::sleep_for(Milliseconds{20});
            g->close();
            break;
          }
        }
      }
      std::this_thread::sleep_for(Milliseconds{50});
      done = true;
      pinger.join();
      if (!why.empty()) return why;
      if (unanswered.load() > 0) {
        return std::to_string(unanswered.load()) + " of the observer's Pings went unanswered";
      }
      if (answered.load() == 0) return std::string("the observer got no Pong at all");
      return still_usable(*observer);
    });
  }

  const GlobalOptions& options_;
  std::string vectors_dir_;
  bool allow_motion_on_real_robot_ = false;
  std::ostream& out_;
  int passed_ = 0;
  int failed_ = 0;
  int skipped_ = 0;
  // Non-empty: the checks that move the base (or the arm) are refused, and this says why.
  std::string motion_refused_;
  std::optional<protocol::RobotModel> model_;
  double yaw_before_align_ = 0;
};

}  // namespace

std::string motion_refusal(std::optional<protocol::DriverKind> kind,
                           bool allow_motion_on_real_robot) {
  if (allow_motion_on_real_robot) return {};
  if (!kind) {
    return "the daemon speaks protocol 1.0 and does not say whether it drives real hardware; "
           "the checks that move the base are not run without --allow-motion-on-real-robot";
  }
  if (*kind == protocol::DriverKind::kReal) {
    return "the daemon drives the real robot (Welcome.driver_kind = real): the checks that turn "
           "or drive the base and engage the arm are not run without "
           "--allow-motion-on-real-robot (clear the robot's surroundings first)";
  }
  return {};
}

int run_conformance(const Command& command, const GlobalOptions& options, std::ostream& out,
                    std::ostream& err) {
  std::string vectors = default_vectors_dir();
  bool allow_motion_on_real_robot = false;
  for (std::size_t i = 0; i < command.args.size(); ++i) {
    if (command.args[i] == "--vectors" && i + 1 < command.args.size()) {
      vectors = command.args[++i];
    } else if (command.args[i] == "--allow-motion-on-real-robot") {
      allow_motion_on_real_robot = true;
    } else {
      err << "ajarctl: conformance takes [--vectors DIR] [--allow-motion-on-real-robot], got '"
          << command.args[i] << "'\n";
      return kExitUsage;
    }
  }
  Suite suite(options, vectors, allow_motion_on_real_robot, out);
  return suite.run();
}

}  // namespace ajar::client
