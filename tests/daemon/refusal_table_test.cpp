// The message table's refusal column (protocol/message_table.hpp, docs/protocol.md 4.3) against
// the daemon that answers: the real SessionHub over fake links in front of the real engine (its
// loop run by hand on a fake clock over the deterministic mock card and the mock arm; for a stalled
// loop, its own control thread), with ajard's black box over a real recorder. Every Error any
// session receives is checked against its request's row (an Error outside the row fails, whatever
// the scenario), and:
//   - EveryRefusalOfTheTableIsProduced: directed scenarios bring the daemon into each refusal;
//     every (code, field) of every row must have been received at least once — the table lists
//     nothing the daemon never says;
//   - RandomRequestsAreRefusedOnlyAsTheTableSays: random sequences of requests (every request
//     type, valid and invalid values, the roles, loop cycles, arm and card faults) — every Error
//     must be in its request's row.
//
//   AJAR_SEED=<n>   replay one seed of the campaign (prints its trace)
//   AJAR_SEEDS=<n>  number of seeds (default 30, 6 under sanitizers)
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <deque>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/recordings.hpp"
#include "ajar/daemon/session_hub.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/message_table.hpp"
#include "ajar/recorder/channels.hpp"
#include "ajar/recorder/recorder.hpp"
#include "campaign_seeds.hpp"
#include "det_mock_card.hpp"
#include "fake_door.hpp"
#include "fake_engine_fixture.hpp"
#include "recording_link.hpp"

namespace ajar::testing::refusal_table {
namespace {

using namespace std::chrono_literals;
using drivers::CardCall;
using protocol::Message;
using protocol::MessageType;
using protocol::ProcedureState;
using protocol::Refusal;
using protocol::Role;

constexpr std::int64_t kPeriodNs = 2'000'000;  // 500 Hz
constexpr int kForever = std::numeric_limits<int>::max();
constexpr std::uint64_t kCiSeeds = test::ci_size(30, 6);
constexpr double kCardSpeedup = 20;  // the card on the steady clock (a stalled loop's world)

// (request type, index of the refusal in its row).
using Covered = std::set<std::pair<MessageType, std::size_t>>;

class Link final : public RecordingLink {
 public:
  Link(std::uint64_t id, daemon::PeerAccess access)
      : RecordingLink(id, 0x3000 + id, 52000 + id), access_(std::move(access)) {}
  const daemon::PeerAccess& access() const noexcept override { return access_; }
  daemon::PeerAccess access_;
  std::size_t read = 0;                        // frames already looked at
  std::map<std::uint32_t, Message> unclaimed;  // replies read, not yet asked for
};

// ajard's black box over a real recorder (make_recorder_recordings), answered before handle()
// returns; or, held, never answered (the hub's limit on outstanding requests, its time limit).
class TestRecordings final : public daemon::Recordings {
 public:
  explicit TestRecordings(const std::string& directory) {
    recorder::RecorderSettings settings;
    settings.directory = directory;
    recorder_ = std::make_unique<recorder::Recorder>(settings, [](std::string_view) {});
    recorder_->start();
    const std::vector<std::uint8_t> frame(100, 0x42);
    for (std::uint64_t i = 0; i < 10; ++i)
      recorder_->frame(recorder::kWireIn, 1, i * 1000, frame);
    real_ = daemon::make_recorder_recordings(*recorder_, io_);
  }
  ~TestRecordings() override {
    real_.reset();
    recorder_->stop();
  }
  void handle(const Message& request, Done done) override {
    if (hold) {
      held.push_back(std::move(done));
      return;
    }
    std::optional<Message> answer;
    real_->handle(request, [&](Message m) { answer = std::move(m); });
    const auto until = std::chrono::steady_clock::now() + 20s;
    while (!answer && std::chrono::steady_clock::now() < until) {
      io_.restart();
      io_.run_for(5ms);
    }
    EXPECT_TRUE(answer.has_value()) << "the black box did not answer";
    done(answer.value_or(protocol::ErrorReply{}));
  }
  bool hold = false;
  std::deque<Done> held;

 private:
  boost::asio::io_context io_;
  std::unique_ptr<recorder::Recorder> recorder_;
  std::unique_ptr<daemon::Recordings> real_;
};

struct Options {
  bool manual_loop = true;  // false: the engine's own control thread (a stalled loop)
  bool recordings = true;   // false: the hub has no black box (NOT_SUPPORTED)
  std::function<void(daemon::Config&)> configure = {};
};

// The hub, the engine and its drivers, and the sessions; every Error any session gets is checked.
class World {
 public:
  World(Covered& covered, std::vector<std::string>& violations, Options options = {})
      : covered_(covered), violations_(violations), manual_(options.manual_loop) {
    config = test_config(dir_.path());
    config.recorder.enabled = false;
    config.safety.deadman_timeout_s = 30;
    config.safety.arm_task_timeout_s = 60;
    config.safety.arm_stop_timeout_s = 30;
    config.control.motion_timeout_margin_s = 2;
    if (options.configure) options.configure(config);
    drivers::DriverSet set;
    daemon::EngineOptions engine_options;
    if (manual_) {
      auto det = make_det_card(clock);
      card = det.get();
      set.card = std::move(det);
      auto mock_arm = std::make_unique<drivers::MockManipulator>(drivers::MockArmFault::kStuck, 50,
                                                                 clock.clock());
      arm = mock_arm.get();
      set.arm = std::move(mock_arm);
      engine_options.now_ns = clock.clock();
      engine_options.manual_loop = true;
    } else {
      auto mock_card =
          std::make_unique<drivers::MockMotionCard>(drivers::MockFault::kNone, 0, kCardSpeedup);
      card = mock_card.get();
      set.card = std::move(mock_card);
      set.arm = make_mock_arm(arm);
      config.drivers.sim_speedup = kCardSpeedup;
    }
    engine = daemon::make_engine(config, std::move(set), std::move(engine_options));
    if (options.recordings) recordings = std::make_unique<TestRecordings>(dir_.path() + "/bb");
    daemon::SessionHub::Options hub_options;
    hub_options.recordings = recordings.get();
    hub = std::make_unique<daemon::SessionHub>(*engine, hub_options);
    engine->set_event_sink([this](const protocol::Event& e) { hub->on_event(e); });
    engine->start();
    cycles(3);
  }
  ~World() {
    if (card != nullptr) card->release_blocked_calls();
    engine->set_event_sink([](const protocol::Event&) {});
    for (auto& l : links_)
      hub->on_closed(*l, "end");
    hub.reset();
    engine->shutdown();
  }

  Link& open(daemon::PeerAccess access = {}) {
    links_.push_back(std::make_unique<Link>(links_.size() + 1, std::move(access)));
    hub->on_open(*links_.back());
    return *links_.back();
  }
  // A greeted session (Hello said 1.`minor`).
  Link& greeted(Role role, std::uint8_t minor = protocol::kVersionMinor, bool take_over = false,
                daemon::PeerAccess access = {}) {
    Link& l = open(std::move(access));
    const Message welcome = request(l, hello(role, minor, take_over));
    EXPECT_TRUE(std::holds_alternative<protocol::Welcome>(welcome)) << describe(welcome);
    return l;
  }
  static protocol::Hello hello(Role role, std::uint8_t minor = protocol::kVersionMinor,
                               bool take_over = false) {
    protocol::Hello h;
    h.version_major = protocol::kVersionMajor;
    h.version_minor = minor;
    h.requested_role = role;
    h.take_over = take_over;
    h.client_instance_id = 0;
    h.client_name = "refusals";
    return h;
  }

  // Hands `m` to the hub as one read of `l` (or to the handler of a refused connection); the
  // request id.
  std::uint32_t send(Link& l, const Message& m, bool refused_connection = false) {
    const std::uint32_t rid = ++next_rid_;
    const protocol::Envelope e{rid, 0, m};
    if (refused_connection) {
      hub->refusal_handler().on_message(l, e);
    } else {
      hub->on_read_begin(l);
      hub->on_message(l, e);
      hub->on_read_end(l);
    }
    return rid;
  }
  // The reply to request `rid` of `l` (a durable Ack waits for its save).
  Message reply_to(Link& l, std::uint32_t rid) {
    for (int i = 0; i < 20000; ++i) {
      if (auto r = take(l, rid)) return *r;
      engine->poll();
      hub->tick(daemon::SessionHub::Clock::now());
      std::this_thread::sleep_for(1ms);
    }
    ADD_FAILURE() << "no reply to request " << rid << " on session " << l.id() << " ("
                  << l.frames.size() << " frames)";
    return protocol::ErrorReply{};
  }
  Message request(Link& l, const Message& m, bool refused_connection = false) {
    return reply_to(l, send(l, m, refused_connection));
  }
  // `m` from `l` must be refused with (code, field).
  void refused(Link& l, const Message& m, ErrorCode code, std::string_view field,
               bool refused_connection = false) {
    const Message r = request(l, m, refused_connection);
    const auto* e = std::get_if<protocol::ErrorReply>(&r);
    EXPECT_TRUE(e != nullptr && e->code == code && e->field.view() == field)
        << protocol::to_string(protocol::type_of(m)) << ": expected " << to_string(code) << " '"
        << field << "', got " << describe(r);
  }
  void accepted(Link& l, const Message& m) {
    const Message r = request(l, m);
    EXPECT_FALSE(std::holds_alternative<protocol::ErrorReply>(r))
        << protocol::to_string(protocol::type_of(m)) << ": " << describe(r);
  }

  // Loop cycles on the fake clock (the controller alive); with the control thread: a short wait.
  void cycles(int n) {
    for (int i = 0; i < n; ++i) {
      if (manual_) {
        clock.advance_ns(kPeriodNs);
        engine->controller_heartbeat();
        engine->run_loop_cycle();
      } else {
        std::this_thread::sleep_for(2ms);
      }
      engine->poll();
      hub->tick(daemon::SessionHub::Clock::now());
      for (auto& l : links_)
        take(*l, 0);
    }
  }
  // Cycles until the wheels rest (bounded).
  void settle() {
    for (int i = 0; i < 5000 && !engine->wheels_at_rest(); ++i)
      cycles(1);
    cycles(2);
  }
  // Jogs at (v, w) for `seconds`, then releases the key and waits for rest.
  void jog(Link& c, double v, double w, double seconds) {
    accepted(c, protocol::Drive{v, w});
    const int n = static_cast<int>(seconds / 0.002);
    for (int i = 0; i < n; ++i) {
      if (i % 25 == 0) (void)request(c, protocol::Drive{v, w});
      cycles(1);
    }
    (void)request(c, protocol::Drive{0, 0});
    settle();
  }
  ProcedureState state() const { return engine->status().state; }

  static std::string describe(const Message& m) {
    if (const auto* e = std::get_if<protocol::ErrorReply>(&m)) {
      return "Error " + std::string(to_string(e->code)) + " '" + std::string(e->field.view()) +
             "': " + std::string(e->message.view());
    }
    return std::string(protocol::to_string(protocol::type_of(m)));
  }

  TempDir dir_;
  daemon::Config config;
  FakeClock clock;
  drivers::MockMotionCard* card = nullptr;
  drivers::MockManipulator* arm = nullptr;
  std::unique_ptr<daemon::Engine> engine;
  std::unique_ptr<TestRecordings> recordings;
  std::unique_ptr<daemon::SessionHub> hub;

 private:
  // Reads `l`'s new frames, checks every Error; the reply to `rid` if it came (0: none wanted).
  std::optional<Message> take(Link& l, std::uint32_t rid) {
    while (l.read < l.frames.size()) {
      const auto out = protocol::decode_frame(*l.frames[l.read++]);
      if (out.kind != protocol::StreamDecoder::Kind::kMessage) {
        violations_.push_back("a frame that does not decode");
        continue;
      }
      const Message& m = out.envelope.message;
      if (const auto* e = std::get_if<protocol::ErrorReply>(&m)) check(*e);
      if (out.envelope.request_id != 0 && !std::holds_alternative<protocol::Event>(m) &&
          !std::holds_alternative<protocol::Telemetry>(m)) {
        l.unclaimed[out.envelope.request_id] = m;
      }
    }
    const auto it = l.unclaimed.find(rid);
    if (rid == 0 || it == l.unclaimed.end()) return std::nullopt;
    Message found = std::move(it->second);
    l.unclaimed.erase(it);
    return found;
  }
  void check(const protocol::ErrorReply& e) {
    const MessageType type = e.offending_type;
    const Refusal* r = protocol::find_refusal(type, e.code, e.field.view());
    if (r == nullptr) {
      violations_.push_back(std::string(protocol::to_string(type)) + " refused " +
                            std::string(to_string(e.code)) + " '" + std::string(e.field.view()) +
                            "' (" + std::string(e.message.view()) +
                            "): not in its row of the message table");
      return;
    }
    covered_.insert({type, static_cast<std::size_t>(r - protocol::refusals_of(type).data())});
  }

  Covered& covered_;
  std::vector<std::string>& violations_;
  bool manual_;
  std::vector<std::unique_ptr<Link>> links_;
  std::uint32_t next_rid_ = 0;
};

// One message of each request type, with sensible values.
std::vector<Message> one_of_each() {
  std::vector<Message> out;
  out.emplace_back(World::hello(Role::kObserver));
  out.emplace_back(protocol::Ping{1});
  out.emplace_back(good_width());
  out.emplace_back(good_handle());
  out.emplace_back(plane_at_yaw(0.1));
  out.emplace_back(good_contact());
  out.emplace_back(protocol::AlignBase{});
  out.emplace_back(protocol::Engage{});
  out.emplace_back(protocol::Stop{});
  out.emplace_back(protocol::EmergencyStop{});
  out.emplace_back(protocol::Reset{false});
  out.emplace_back(protocol::GetStatus{});
  out.emplace_back(protocol::Subscribe{0});
  out.emplace_back(protocol::Drive{0.1, 0});
  out.emplace_back(protocol::Approach{0.6});
  out.emplace_back(protocol::GetRobotModel{});
  out.emplace_back(protocol::ResetLoopStatistics{});
  out.emplace_back(protocol::ListRecordings{0});
  protocol::FetchRecording fetch;
  fetch.name = "x.mcap";
  fetch.max_length = 8;
  out.emplace_back(fetch);
  out.emplace_back(protocol::SaveRecording{10});
  return out;
}

// A camera turned 45 degrees about its optical axis: a base coordinate mixes two camera ones, so
// finite picks near the largest double overflow to infinity in the base frame.
void turned_camera(daemon::Config& c) {
  const double s = std::sqrt(0.5);
  Eigen::Matrix4d turn = Eigen::Matrix4d::Identity();
  turn(0, 0) = s;
  turn(0, 1) = -s;
  turn(1, 0) = s;
  turn(1, 1) = s;
  c.camera_to_base_m = forward_camera_to_base_m() * turn;
}
core::FramedPoint huge_camera_point() {
  const double big = std::numeric_limits<double>::max() * 0.9;
  return core::FramedPoint{core::Frame::kCamera, core::Vec3(big, big, 1.5)};
}
core::FramedPoint far_point() {
  return base_point(10.0, 0.0, 1.0);  // beyond the sensor's depth range
}

// The session rules: before Hello, from an observer, on a 1.0 session, on a refused connection,
// for TLS identities, a second or bad Hello, shutdown.
void session_refusals(Covered& covered, std::vector<std::string>& violations) {
  World w(covered, violations);
  Link& controller = w.greeted(Role::kController);
  Link& observer = w.greeted(Role::kObserver);
  Link& anonymous = w.open();
  Link& old = w.greeted(Role::kObserver, 0);
  daemon::PeerAccess no_stop;
  no_stop.identity = "cn:watcher";
  no_stop.may_control = false;
  no_stop.may_stop = false;
  Link& watcher = w.greeted(Role::kObserver, protocol::kVersionMinor, false, no_stop);
  Link& refused = w.open(no_stop);
  for (const Message& m : one_of_each()) {
    const MessageType t = protocol::type_of(m);
    if (t != MessageType::kHello && !protocol::is_stop(t)) {
      w.refused(anonymous, m, ErrorCode::kHelloRequired, "");
    }
    if (protocol::needs_controller(t)) w.refused(observer, m, ErrorCode::kNotController, "");
    if (protocol::minor_of(t) > 0) {
      w.refused(old, m, ErrorCode::kUnknownMessageType, protocol::refusal_field::kHeaderType);
    }
    if (protocol::is_stop(t)) w.refused(watcher, m, ErrorCode::kNotController, "");
    w.refused(refused, m, ErrorCode::kTooManyClients, "", true);
  }
  w.refused(observer, World::hello(Role::kObserver), ErrorCode::kAlreadyGreeted, "");
  protocol::Hello bad = World::hello(Role::kObserver);
  bad.version_major = 7;
  w.refused(anonymous, bad, ErrorCode::kUnsupportedVersion, protocol::refusal_field::kVersionMajor);
  w.refused(anonymous, World::hello(Role::kController), ErrorCode::kControllerBusy,
            protocol::refusal_field::kTakeOver);
  Link& tls = w.open(no_stop);
  w.refused(tls, World::hello(Role::kController, protocol::kVersionMinor, true),
            ErrorCode::kNotController, protocol::refusal_field::kRequestedRole);
  w.refused(observer, protocol::Subscribe{-1}, ErrorCode::kRateLimited,
            protocol::refusal_field::kTelemetryRate);
  (void)controller;
  w.hub->begin_shutdown();
  for (const Message& m : one_of_each()) {
    if (!protocol::is_stop(protocol::type_of(m)))
      w.refused(controller, m, ErrorCode::kShuttingDown, "");
  }
}

// The black box: off, too many outstanding, no answer in time, bad names and ranges.
void black_box_refusals(Covered& covered, std::vector<std::string>& violations) {
  namespace rf = protocol::refusal_field;
  const std::vector<Message> asks = {Message{protocol::ListRecordings{0}},
                                     Message{protocol::FetchRecording{}},
                                     Message{protocol::SaveRecording{10}}};
  {
    World off(covered, violations, Options{.recordings = false});
    Link& o = off.greeted(Role::kObserver);
    for (const Message& m : asks)
      off.refused(o, m, ErrorCode::kNotSupported, "");
  }
  World w(covered, violations);
  Link& o = w.greeted(Role::kObserver);
  protocol::FetchRecording fetch;
  fetch.name = "../x.mcap";
  fetch.max_length = 8;
  w.refused(o, fetch, ErrorCode::kNoSuchRecording, rf::kName);
  fetch.name = "ajard-19700101T000000000Z.mcap";
  w.refused(o, fetch, ErrorCode::kNoSuchRecording, rf::kName);
  fetch.max_length = 0;
  w.refused(o, fetch, ErrorCode::kRequestOutOfRange, rf::kMaxLength);
  w.refused(o, protocol::SaveRecording{0}, ErrorCode::kRequestOutOfRange, rf::kLastS);
  // A recording's name from the list, then an offset past its end.
  std::string name;
  for (int i = 0; i < 2000 && name.empty(); ++i) {
    const Message list = w.request(o, protocol::ListRecordings{0});
    if (const auto* l = std::get_if<protocol::RecordingList>(&list); l != nullptr && l->count > 0)
      name = std::string(l->entries[0].name.view());
    else
      std::this_thread::sleep_for(5ms);
  }
  ASSERT_FALSE(name.empty()) << "the recorder listed no recording";
  fetch.name = std::string_view(name);
  fetch.max_length = 8;
  fetch.offset = 1ULL << 40;
  w.refused(o, fetch, ErrorCode::kRequestOutOfRange, rf::kOffset);
  // Held: the hub's limit on outstanding requests, then its time limit.
  w.recordings->hold = true;
  for (const Message& m : asks) {
    std::vector<std::uint32_t> rids;
    for (std::size_t i = 0; i < daemon::SessionHub::kMaxRecordingsPending; ++i)
      rids.push_back(w.send(o, m));
    const std::uint32_t full = w.send(o, m);  // its Error keeps its place behind the others
    w.hub->tick(daemon::SessionHub::Clock::now() + 3 * daemon::SessionHub::kHeldReplyLimit);
    const auto code = [](const Message& r) {
      const auto* e = std::get_if<protocol::ErrorReply>(&r);
      return e == nullptr ? ErrorCode::kOk : e->code;
    };
    const Message late = w.reply_to(o, rids.front());
    EXPECT_EQ(code(late), ErrorCode::kDriverError) << World::describe(late);
    for (std::size_t i = 1; i < rids.size(); ++i)
      (void)w.reply_to(o, rids[i]);
    const Message refused = w.reply_to(o, full);
    EXPECT_EQ(code(refused), ErrorCode::kQueueFull) << World::describe(refused);
  }
}

// Two-point picks (`make(p1, p2)`): each point out of range, too close, in depth, not side by
// side, then the pair `wide_p1`, `wide_p2` out of the measurement's range.
template <typename Make>
void two_point_refusals(World& w, Link& c, Make make, std::string_view range_field,
                        ErrorCode range_code, core::FramedPoint wide_p1,
                        core::FramedPoint wide_p2) {
  namespace cf = core::fields;
  const auto ok1 = base_point(1.5, 0.40, 1.0);
  const auto ok2 = base_point(1.5, -0.20, 1.0);
  w.refused(c, make(far_point(), ok2), ErrorCode::kPointOutOfDepthRange, cf::kP1);
  w.refused(c, make(ok1, far_point()), ErrorCode::kPointOutOfDepthRange, cf::kP2);
  w.refused(c, make(ok1, ok1), ErrorCode::kPointsTooClose, cf::kP2);
  w.refused(c, make(ok1, base_point(2.0, 0.40, 1.0)), ErrorCode::kAmbiguousDirection, cf::kP2);
  w.refused(c, make(ok1, base_point(2.5, 0.30, 1.0)), ErrorCode::kPointsNotSideBySide, cf::kP2);
  w.refused(c, make(wide_p1, wide_p2), range_code, range_field);
}

// Nothing measured yet; then the width's and the handle's picks, each accepted in the end.
void width_and_handle_refusals(World& w, Link& c) {
  namespace rf = protocol::refusal_field;
  namespace cf = core::fields;
  // Nothing measured.
  for (const Message& m :
       {Message{good_handle()}, Message{plane_at_yaw(0.1)}, Message{good_contact()},
        Message{protocol::AlignBase{}}, Message{protocol::Engage{}}})
    w.refused(c, m, ErrorCode::kMissingDoorWidth, "");
  w.refused(c, protocol::Approach{0.6}, ErrorCode::kNoDoorDistance, "");
  w.refused(c, protocol::Approach{0.1}, ErrorCode::kStandoffOutOfRange, rf::kStandoff);
  two_point_refusals(
      w, c,
      [](auto a, auto b) {
        return Message{protocol::MeasureDoorWidth{a, b}};
      },
      cf::kWidth, ErrorCode::kWidthOutOfRange, base_point(1.5, 1.2, 1.0),
      base_point(1.5, -1.3, 1.0));
  w.accepted(c, good_width());
  for (const Message& m : {Message{plane_at_yaw(0.1)}, Message{good_contact()},
                           Message{protocol::AlignBase{}}, Message{protocol::Engage{}}})
    w.refused(c, m, ErrorCode::kMissingHandle, "");
  two_point_refusals(
      w, c,
      [](auto a, auto b) {
        return Message{protocol::MeasureHandle{a, b}};
      },
      cf::kHandleLength, ErrorCode::kHandleLengthOutOfRange, base_point(1.45, 0.2, 1.0),
      base_point(1.45, -0.42, 1.0));
  w.accepted(c, good_handle());
}

// The plane's picks, then the plane 0.65 rad off, within the correction (0.7 rad), accepted.
void plane_refusals(World& w, Link& c) {
  namespace cf = core::fields;
  for (const Message& m :
       {Message{good_contact()}, Message{protocol::AlignBase{}}, Message{protocol::Engage{}}})
    w.refused(c, m, ErrorCode::kMissingPlane, "");
  auto plane = plane_at_yaw(0.1);
  plane.points[1] = far_point();
  w.refused(c, plane, ErrorCode::kPointOutOfDepthRange, core::point_field(1));
  plane = plane_at_yaw(0.1);
  plane.points[2] = plane.points[0];
  w.refused(c, plane, ErrorCode::kPointsTooClose, core::point_field(2));
  w.refused(c, collinear_plane(), ErrorCode::kPointsCollinear, cf::kPoints);
  protocol::MeasureDoorPlane floor;
  floor.count = 3;
  floor.points[0] = base_point(1.5, 0.3, 0.0);
  floor.points[1] = base_point(1.5, -0.3, 0.0);
  floor.points[2] = base_point(2.0, 0.0, 0.0);
  w.refused(c, floor, ErrorCode::kPlaneNotVertical, cf::kPoints);
  auto bumpy = plane_at_yaw(0.0);
  bumpy.count = 4;
  bumpy.points[3] = base_point(1.7, 0.0, 0.9);
  w.refused(c, bumpy, ErrorCode::kPlaneResidualTooLarge, cf::kRmsResidual);
  w.refused(c, plane_at_yaw(1.0), ErrorCode::kYawOutOfRange, cf::kYawDeviation);
  w.accepted(c, plane_at_yaw(0.65));
}

// Ready to align: what waits for the alignment, a correction grown too large, a stale plane, the
// approach's own checks, then aligned: the contact point's refusals, and a stale contact point.
void alignment_refusals(World& w, Link& c) {
  namespace rf = protocol::refusal_field;
  namespace cf = core::fields;
  w.refused(c, good_contact(), ErrorCode::kNotAligned, "");
  w.refused(c, protocol::Engage{}, ErrorCode::kNotAligned, "");
  w.refused(c, protocol::Approach{0.6}, ErrorCode::kNotSquareToDoor, rf::kDoorYaw);
  // Turning the base 0.15 rad (less than the staleness) away from the door: the correction asked
  // for grows beyond the maximum.
  w.jog(c, 0, 0.3, 0.5);
  w.refused(c, protocol::AlignBase{}, ErrorCode::kYawOutOfRange, cf::kYawDeviation);
  // Turning on: the plane is stale.
  w.jog(c, 0, 0.3, 0.5);
  for (const Message& m : {Message{good_contact()}, Message{protocol::AlignBase{}},
                           Message{protocol::Engage{}}, Message{protocol::Approach{0.6}}})
    w.refused(c, m, ErrorCode::kMeasurementStale, rf::kPlane);
  // Square to the door: the approach's own checks.
  w.accepted(c, plane_at_yaw(0.0));
  w.refused(c, protocol::Approach{4.0}, ErrorCode::kApproachTooFar, rf::kStandoff);
  w.accepted(c, protocol::AlignBase{});  // nothing to turn: aligned at once
  w.refused(c, protocol::AlignBase{}, ErrorCode::kWrongState, "");
  w.refused(c, protocol::Engage{}, ErrorCode::kMissingContactPoint, "");
  w.refused(c, unreachable_contact(), ErrorCode::kOutOfReach, cf::kContact);
  w.refused(c, protocol::SetContactPoint{far_point()}, ErrorCode::kPointOutOfDepthRange,
            cf::kContact);
  // The contact point set about 0.08 m ahead of where the base was aligned, then the base backs off
  // about 0.14 m: the contact point is stale (0.14 m > 0.1 m), the plane not (0.06 m).
  w.jog(c, 0.1, 0, 0.8);
  w.accepted(c, good_contact());
  w.jog(c, -0.1, 0, 1.4);
  w.refused(c, protocol::Engage{}, ErrorCode::kMeasurementStale, rf::kContact);
}

// While a jog runs: measurements wait for rest, Approach too. Then a fault latched.
void motion_and_fault_refusals(World& w, Link& c) {
  w.accepted(c, protocol::Drive{-0.1, 0});
  w.cycles(20);
  w.refused(c, good_width(), ErrorCode::kMotionInProgress, "");
  w.refused(c, protocol::Approach{0.6}, ErrorCode::kMotionInProgress, "");
  (void)w.request(c, protocol::Drive{0, 0});
  w.settle();
  // A fault latched.
  w.accepted(c, protocol::EmergencyStop{});
  for (const Message& m :
       {Message{good_width()}, Message{good_handle()}, Message{plane_at_yaw(0.0)},
        Message{good_contact()}, Message{protocol::AlignBase{}}, Message{protocol::Engage{}},
        Message{protocol::Drive{0.1, 0}}, Message{protocol::Approach{0.6}}})
    w.refused(c, m, ErrorCode::kFaultLatched, "");
}

// The measurements' validation (core) and the procedure's order, for each request in turn.
void procedure_refusals(Covered& covered, std::vector<std::string>& violations) {
  World w(covered, violations, Options{.configure = [](daemon::Config& c) {
            c.drive.stale_travel_m = 0.1;
            c.drive.stale_yaw_rad = 0.2;
          }});
  Link& c = w.greeted(Role::kController);
  width_and_handle_refusals(w, c);
  plane_refusals(w, c);
  ASSERT_EQ(w.state(), ProcedureState::kReadyToAlign);
  alignment_refusals(w, c);
  motion_and_fault_refusals(w, c);
}

// Picks whose base-frame coordinates overflow (a turned camera): NON_FINITE naming the coordinate.
void non_finite_refusals(Covered& covered, std::vector<std::string>& violations) {
  namespace cf = core::fields;
  World w(covered, violations, Options{.configure = turned_camera});
  Link& c = w.greeted(Role::kController);
  const auto ok1 = base_point(1.5, 0.40, 1.0);
  const auto ok2 = base_point(1.5, -0.45, 1.0);
  const std::string p1z = std::string(cf::kP1) + ".z";
  const std::string p2z = std::string(cf::kP2) + ".z";
  w.refused(c, protocol::MeasureDoorWidth{huge_camera_point(), ok2}, ErrorCode::kNonFinite, p1z);
  w.refused(c, protocol::MeasureDoorWidth{ok1, huge_camera_point()}, ErrorCode::kNonFinite, p2z);
  w.accepted(c, good_width());
  w.refused(c, protocol::MeasureHandle{huge_camera_point(), ok2}, ErrorCode::kNonFinite, p1z);
  w.refused(c, protocol::MeasureHandle{ok1, huge_camera_point()}, ErrorCode::kNonFinite, p2z);
  w.accepted(c, good_handle());
  auto plane = plane_at_yaw(0.0);
  plane.points[2] = huge_camera_point();
  w.refused(c, plane, ErrorCode::kNonFinite, core::point_field(2) + ".z");
  w.accepted(c, plane_at_yaw(0.0));
  w.accepted(c, protocol::AlignBase{});  // nothing to turn
  w.refused(c, protocol::SetContactPoint{huge_camera_point()}, ErrorCode::kNonFinite,
            std::string(cf::kContact) + ".z");
}

// Ready to engage at the door (a fresh world each time the arm must start clean).
void to_ready_to_engage(World& w, Link& c) {
  w.accepted(c, good_width());
  w.accepted(c, good_handle());
  w.accepted(c, plane_at_yaw(0.1));
  w.accepted(c, protocol::AlignBase{});
  w.settle();
  ASSERT_EQ(w.state(), ProcedureState::kAligned);
  w.accepted(c, good_contact());
  ASSERT_EQ(w.state(), ProcedureState::kReadyToEngage);
}

// Motions and the arm: aligning, engaging, engaged, an arm that is not clear or not there.
void motion_and_arm_refusals(Covered& covered, std::vector<std::string>& violations) {
  namespace rf = protocol::refusal_field;
  {
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    w.accepted(c, good_width());
    w.accepted(c, good_handle());
    w.accepted(c, plane_at_yaw(0.1));
    w.accepted(c, protocol::AlignBase{});  // turning
    for (const Message& m :
         {Message{good_width()}, Message{good_handle()}, Message{plane_at_yaw(0.1)},
          Message{good_contact()}, Message{protocol::AlignBase{}}, Message{protocol::Drive{0.1, 0}},
          Message{protocol::Approach{0.6}}})
      w.refused(c, m, ErrorCode::kMotionInProgress, "");
    w.settle();
    w.accepted(c, good_contact());
    w.accepted(c, protocol::Engage{});  // the arm works (and ignores stops)
    w.arm->ignore_stops(true);
    w.refused(c, protocol::Engage{}, ErrorCode::kMotionInProgress, "");
    w.refused(c, protocol::Drive{0.1, 0}, ErrorCode::kDriveNotAllowed, "");
    w.refused(c, protocol::Approach{0.6}, ErrorCode::kDriveNotAllowed, "");
    // Stopped, but the arm goes on: it is not clear of the door.
    w.accepted(c, protocol::Stop{});
    w.cycles(1000);  // past the card's stop time
    w.refused(c, protocol::Drive{0.1, 0}, ErrorCode::kDriveNotAllowed, rf::kArm);
    w.refused(c, protocol::Approach{0.6}, ErrorCode::kDriveNotAllowed, rf::kArm);
    w.refused(c, protocol::Engage{}, ErrorCode::kWrongState, rf::kArm);  // the arm is busy
    w.accepted(c, plane_at_yaw(0.2));  // not aligned any more: AlignBase checks the arm
    w.refused(c, protocol::AlignBase{}, ErrorCode::kDriveNotAllowed, rf::kArm);
    // A fault latched while the arm still works: Reset is refused until it reports idle.
    w.accepted(c, protocol::EmergencyStop{});
    w.cycles(5);
    w.refused(c, protocol::Reset{false}, ErrorCode::kArmNotClear, rf::kArm);
    // The arm faulted and its controller does not answer: the recovery fails.
    w.arm->set_phase(drivers::ArmPhase::kFault, ErrorCode::kArmFault);
    w.arm->go_silent();
    w.refused(c, protocol::Reset{false}, ErrorCode::kArmDisconnected, rf::kArm);
  }
  {
    // Engaged: Engage again is the wrong state.
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    to_ready_to_engage(w, c);
    w.accepted(c, protocol::Engage{});
    w.arm->set_phase(drivers::ArmPhase::kDone);
    w.cycles(5);
    ASSERT_EQ(w.state(), ProcedureState::kEngaged);
    w.refused(c, protocol::Engage{}, ErrorCode::kWrongState, "");
  }
  {
    // The arm's controller does not answer: the hand-off is refused.
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    to_ready_to_engage(w, c);
    w.arm->go_silent();
    w.refused(c, protocol::Engage{}, ErrorCode::kArmDisconnected, rf::kArm);
  }
  {
    // The arm's driver failed on a stop: it is no longer active, the hand-off is refused.
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    to_ready_to_engage(w, c);
    w.arm->fail_next_call(make_error(ErrorCode::kDriverError, "", "the test's failure"));
    (void)w.request(c, protocol::Stop{});
    w.cycles(5);
    w.refused(c, protocol::Engage{}, ErrorCode::kDriverNotActive, rf::kArm);
  }
}

// The card and the loop: the door guard, a full command queue, wheels that ignore their stops.
void loop_refusals(Covered& covered, std::vector<std::string>& violations) {
  namespace rf = protocol::refusal_field;
  {
    // The door 0.45 m ahead: a forward jog stops at 0.4 m; there, forward is refused.
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    w.accepted(
        c, protocol::MeasureDoorWidth{base_point(0.45, 0.40, 1.0), base_point(0.45, -0.45, 1.0)});
    w.jog(c, 0.1, 0, 3.0);
    w.refused(c, protocol::Drive{0.1, 0}, ErrorCode::kAtMinimumStandoff, rf::kLinear);
  }
  {
    // The loop's command queue full: every new door line posts the loop's jog guard, and the
    // loop (run by hand) takes nothing.
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    w.accepted(c, good_width());
    w.accepted(c, good_handle());
    bool full = false;
    for (int i = 1; i <= 100 && !full; ++i) {
      w.accepted(c, plane_at_yaw(0.1 + 0.0005 * i));
      const Message r = w.request(c, protocol::Drive{0, 0});
      const auto* e = std::get_if<protocol::ErrorReply>(&r);
      full = e != nullptr && e->code == ErrorCode::kQueueFull;
    }
    ASSERT_TRUE(full) << "the loop's command queue never filled";
    w.accepted(c, protocol::EmergencyStop{});
    w.refused(c, protocol::Reset{false}, ErrorCode::kQueueFull, "");
  }
  {
    // Wheels that go on turning after an emergency stop: Reset waits for them.
    World w(covered, violations);
    Link& c = w.greeted(Role::kController);
    w.accepted(c, protocol::Drive{0.3, 0});
    for (int i = 0; i < 400; ++i) {
      if (i % 25 == 0) (void)w.request(c, protocol::Drive{0.3, 0});
      w.cycles(1);
    }
    w.card->drop_next_calls(CardCall::kSmoothStop, kForever);
    w.card->drop_next_calls(CardCall::kEmergencyStop, kForever);
    w.card->drop_next_calls(CardCall::kDisableAxes, kForever);
    w.accepted(c, protocol::EmergencyStop{});
    w.cycles(200);
    w.refused(c, protocol::Reset{false}, ErrorCode::kMotionInProgress, "");
  }
  {
    // A stalled loop (its own control thread; a card call hangs): Reset waits for it.
    World w(covered, violations, Options{.manual_loop = false});
    Link& c = w.greeted(Role::kController);
    w.card->block_calls(CardCall::kAxisStatus, 1);
    for (int i = 0; i < 10000 && w.engine->status().latched_fault != ErrorCode::kLoopStalled; ++i)
      w.cycles(1);
    ASSERT_EQ(w.engine->status().latched_fault, ErrorCode::kLoopStalled);
    w.refused(c, protocol::Reset{false}, ErrorCode::kLoopStalled, "");
    w.card->release_blocked_calls();
  }
}

std::string uncovered_list(const Covered& covered) {
  std::string out;
  for (std::uint16_t raw = 0x0100; raw < 0x0200; ++raw) {
    const auto t = static_cast<MessageType>(raw);
    const auto row = protocol::refusals_of(t);
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (covered.count({t, i})) continue;
      out += "\n  " + std::string(protocol::to_string(t)) + ": " +
             std::string(to_string(row[i].code)) + " " + protocol::field_pattern(row[i]);
    }
  }
  return out;
}

TEST(RefusalTable, EveryRefusalOfTheTableIsProduced) {
  Covered covered;
  std::vector<std::string> violations;
  session_refusals(covered, violations);
  black_box_refusals(covered, violations);
  procedure_refusals(covered, violations);
  non_finite_refusals(covered, violations);
  motion_and_arm_refusals(covered, violations);
  loop_refusals(covered, violations);
  for (const auto& v : violations)
    ADD_FAILURE() << v;
  const std::string missing = uncovered_list(covered);
  EXPECT_TRUE(missing.empty()) << "refusals of the message table no scenario produced:" << missing;
}

// ---- the campaign ---------------------------------------------------------------------------

class Campaign {
 public:
  Campaign(std::uint64_t seed, Covered& covered, std::vector<std::string>& violations, bool verbose)
      : rng_(seed), verbose_(verbose), w_(covered, violations, options(seed)) {
    controller_ = &w_.greeted(Role::kController);
    observer_ = &w_.greeted(Role::kObserver);
    anonymous_ = &w_.open();
    old_ = &w_.greeted(Role::kObserver, 0);
  }
  void run(int steps) {
    for (int i = 0; i < steps; ++i)
      step();
  }
  const std::vector<std::string>& trace() const { return trace_; }

 private:
  static Options options(std::uint64_t seed) {
    Options o;
    if (seed % 3 == 0) o.configure = turned_camera;
    return o;
  }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(rng_); }
  int pick(int n) { return std::uniform_int_distribution<>(0, n - 1)(rng_); }
  core::FramedPoint point() {
    switch (pick(6)) {
      case 0:
        return far_point();
      case 1:
        return huge_camera_point();
      case 2:
        return core::FramedPoint{core::Frame::kCamera,
                                 core::Vec3(uniform(-1, 1), uniform(-1, 1), uniform(0.2, 5))};
      default:
        return base_point(uniform(0.3, 2.5), uniform(-1.5, 1.5), uniform(0.0, 2.0));
    }
  }
  Message request() {
    switch (pick(20)) {
      case 0:
        return World::hello(pick(2) ? Role::kController : Role::kObserver);
      case 1:
        return pick(2) ? Message{good_width()}
                       : Message{protocol::MeasureDoorWidth{point(), point()}};
      case 2:
        return pick(2) ? Message{good_handle()}
                       : Message{protocol::MeasureHandle{point(), point()}};
      case 3: {
        if (pick(2)) return plane_at_yaw(uniform(-1.2, 1.2));
        protocol::MeasureDoorPlane p;
        p.count = static_cast<std::uint8_t>(3 + pick(6));
        for (int i = 0; i < p.count; ++i)
          p.points[static_cast<std::size_t>(i)] = point();
        return p;
      }
      case 4:
        return pick(2) ? Message{good_contact()} : Message{protocol::SetContactPoint{point()}};
      case 5:
        return protocol::AlignBase{};
      case 6:
        return protocol::Engage{};
      case 7:
        return protocol::Stop{};
      case 8:
        return pick(4) == 0 ? Message{protocol::EmergencyStop{}} : Message{protocol::Ping{1}};
      case 9:
        return protocol::Reset{pick(3) == 0};
      case 10:
        return protocol::GetStatus{};
      case 11:
        return protocol::Subscribe{static_cast<float>(uniform(-10, 10))};
      case 12:
      case 13:
        return protocol::Drive{uniform(-0.3, 0.3) * pick(2), uniform(-0.5, 0.5) * pick(2)};
      case 14:
        return protocol::Approach{uniform(0, 3)};
      case 15:
        return protocol::GetRobotModel{};
      case 16:
        return protocol::ResetLoopStatistics{};
      case 17:
        return protocol::ListRecordings{static_cast<std::uint32_t>(pick(3))};
      case 18: {
        protocol::FetchRecording f;
        f.name = pick(2) ? "../x.mcap" : "none.mcap";
        f.offset = static_cast<std::uint64_t>(pick(100));
        f.max_length = static_cast<std::uint16_t>(pick(1200));
        return f;
      }
      default:
        return protocol::SaveRecording{static_cast<float>(uniform(-5, 100000))};
    }
  }
  void step() {
    const int what = pick(12);
    if (what < 6) {
      Link* from = what < 4 ? controller_ : what == 4 ? observer_ : pick(2) ? anonymous_ : old_;
      const Message m = request();
      note(std::string(protocol::to_string(protocol::type_of(m))) + " from link " +
           std::to_string(from->id()));
      (void)w_.request(*from, m);
    } else if (what < 10) {
      const int n = 1 + pick(200);
      note(std::to_string(n) + " cycles");
      w_.cycles(n);
    } else if (what == 10) {
      const int f = pick(4);
      note("arm: " + std::to_string(f));
      if (f == 0) w_.arm->set_phase(drivers::ArmPhase::kDone);
      if (f == 1) w_.arm->set_phase(drivers::ArmPhase::kIdle);
      if (f == 2) w_.arm->ignore_stops(pick(2) == 0);
      if (f == 3) {
        w_.arm->go_silent();
        w_.cycles(1);
        w_.arm->answer_again();
      }
    } else {
      note("a new controller (take-over)");
      controller_ = &w_.greeted(Role::kController, protocol::kVersionMinor, true);
    }
  }
  void note(std::string line) {
    if (verbose_) std::cout << line << "\n";
    trace_.push_back(std::move(line));
  }

  std::mt19937_64 rng_;
  bool verbose_;
  std::vector<std::string> trace_;
  World w_;
  Link* controller_ = nullptr;
  Link* observer_ = nullptr;
  Link* anonymous_ = nullptr;
  Link* old_ = nullptr;
};

TEST(RefusalTable, RandomRequestsAreRefusedOnlyAsTheTableSays) {
  const test::SeedRange seeds = test::seed_range(kCiSeeds);
  Covered covered;
  for (std::uint64_t seed = seeds.first; seed < seeds.first + seeds.count; ++seed) {
    std::vector<std::string> violations;
    {
      Campaign campaign(seed, covered, violations, seeds.replay);
      campaign.run(150);
    }
    if (!violations.empty()) {
      ADD_FAILURE() << "seed " << seed << " (replay: AJAR_SEED=" << seed
                    << "): " << violations.front();
      return;
    }
  }
  std::size_t rows = 0;
  for (std::uint16_t raw = 0x0100; raw < 0x0200; ++raw)
    rows += protocol::refusals_of(static_cast<MessageType>(raw)).size();
  std::cout << "campaign: " << seeds.count << " seeds reached " << covered.size() << " of " << rows
            << " refusals of the table\n";
}

}  // namespace
}  // namespace ajar::testing::refusal_table
