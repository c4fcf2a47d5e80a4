// Wire-level proof of issue 10's I/O side, against the server and the real engine on mock drivers
// (in process) and against the ajard binary: several frames in ONE write (a GUI that queues them,
// a host retrying), a session table full of sockets that never greet, an EmergencyStop while the
// controller's state is being written to a slow disk, durable Acks in request order, a state file
// with impossible content, SIGTERM while the base turns. No timing is asserted: every wait is
// bounded and checks an outcome.
#include <optional>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include <gtest/gtest.h>

#include "ajard_process.hpp"
#include "e2e_fixture.hpp"
#include "state_file_checksum.hpp"

namespace ajar::test {
namespace {

using ajar::testing::with_checksum;
using protocol::EventKind;
using protocol::MessageType;
using protocol::ProcedureState;
using protocol::Role;

// Several requests as ONE write (one TCP segment on loopback).
std::vector<std::uint8_t> one_write(
    std::initializer_list<std::pair<protocol::Message, std::uint32_t>> requests) {
  std::vector<std::uint8_t> bytes;
  for (const auto& [message, id] : requests) {
    const auto f = frame_of(message, id);
    bytes.insert(bytes.end(), f.begin(), f.end());
  }
  return bytes;
}

struct WheelCounts {
  std::int64_t left = 0;
  std::int64_t right = 0;
  bool operator==(const WheelCounts&) const = default;
};

// The wheel positions over the next `frames` telemetry frames (the loop publishes every cycle):
// returns true when they never moved from `at` and nothing was reported moving.
bool wheels_stay_put(TestClient& watcher, WheelCounts at, std::size_t frames = 30) {
  for (std::size_t i = 0; i < frames; ++i) {
    if (!watcher.wait_telemetry(watcher.telemetry_count() + 1)) {
      ADD_FAILURE() << "no telemetry";
      return false;
    }
    const auto& t = *watcher.last_telemetry();
    const WheelCounts now{t.left_counts, t.right_counts};
    if (!(now == at) || t.moving) {
      ADD_FAILURE() << "the wheels turned: left " << at.left << " -> " << now.left << ", right "
                    << at.right << " -> " << now.right << (t.moving ? " (moving)" : "");
      return false;
    }
  }
  return true;
}

WheelCounts counts_now(TestClient& watcher) {
  watcher.wait_telemetry(watcher.telemetry_count() + 1);
  const auto& t = *watcher.last_telemetry();
  return {t.left_counts, t.right_counts};
}

// Waits (bounded) until the telemetry says nothing moves; returns the resting counts.
// Telemetry is streamed at the loop rate and can lag behind replies: with `state`, only a frame
// that already shows that procedure state (produced after the command that led to it) counts.
WheelCounts wait_at_rest(TestClient& watcher, std::optional<ProcedureState> state = std::nullopt) {
  EXPECT_TRUE(eventually([&] {
    return watcher.wait_telemetry(watcher.telemetry_count() + 1) &&
           !watcher.last_telemetry()->moving &&
           (!state || watcher.last_telemetry()->state == *state);
  }));
  return counts_now(watcher);
}

protocol::Status status_of(TestClient& c) {
  return c.request_as<protocol::Status>(protocol::GetStatus{});
}

// Back to ready_to_align after an interrupted alignment (which consumes the plane).
void ready_to_align(TestClient& controller) {
  const auto state = status_of(controller).state;
  if (state == ProcedureState::kReadyToAlign) return;
  if (state == ProcedureState::kAwaitingWidth) {
    measure_door(controller, 0.6);
    return;
  }
  ASSERT_EQ(ack_state(controller.request(plane_at_yaw(0.6))), ProcedureState::kReadyToAlign);
}

// The daemon on mock drivers at real speed (speedup 1), an observer watching telemetry at the loop
// rate and a greeted controller.
struct Watched {
  explicit Watched(const daemon::Config& config)
      : daemon(config), watcher(daemon.port()), controller(daemon.port()) {
    watcher.hello(Role::kObserver);
    watcher.request_as<protocol::Ack>(protocol::Subscribe{1000});
    controller.hello(Role::kController);
  }
  InProcessDaemon daemon;
  TestClient watcher;
  TestClient controller;
};

class StopRaces : public EndToEndOnMock {
 protected:
  // Real speed, and every save of the state file takes `write_delay_ms` (a slow or hung disk).
  daemon::Config slow_disk(int write_delay_ms) {
    auto c = config(1.0);
    c.state.debug_write_delay_ms = write_delay_ms;
    return c;
  }
};

// The bug that opened issue 10: AlignBase and Stop in one write. The Stop is acknowledged, so the
// queued move must never start.
TEST_F(StopRaces, AlignBaseAndStopInOneWriteTurnsNothing) {
  Watched robot(config(1.0));
  auto& [d, w, controller] = robot;
  for (std::uint32_t round = 0; round < 10;
       ++round) {  // the race has several outcomes: try it repeatedly
    SCOPED_TRACE("round " + std::to_string(round));
    ready_to_align(controller);
    const WheelCounts before = wait_at_rest(w);
    controller.send_raw(one_write(
        {{protocol::AlignBase{}, 100u + 2 * round}, {protocol::Stop{}, 101u + 2 * round}}));
    const auto align = controller.reply_to(100 + 2 * round);
    const auto stop = controller.reply_to(101 + 2 * round);
    ASSERT_TRUE(std::holds_alternative<protocol::Ack>(stop)) << TestClient::describe(stop);
    (void)align;  // accepted then cancelled, or refused: either way nothing may turn
    ASSERT_TRUE(wheels_stay_put(w, before));
    ASSERT_NE(status_of(controller).state, ProcedureState::kAligning);
  }
}

// A table full of sockets that never said Hello: a new connection's Hello + EmergencyStop (one
// write) is executed: the fault latches and the wheels stop.
TEST_F(StopRaces, AFullTableOfSilentSocketsCannotLockOutAnEmergencyStop) {
  auto c = config(1.0);
  c.network.max_clients = 24;
  Watched robot(c);
  auto& [d, w, controller] = robot;
  measure_door(controller, 0.6);
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  std::vector<std::unique_ptr<TestClient>> silent;
  while (silent.size() < 22)
    silent.push_back(std::make_unique<TestClient>(d.port()));
  ASSERT_TRUE(eventually([&] { return d.session_count() == 24; }));

  TestClient operator_(d.port());
  operator_.send_raw(one_write({{hello_as(Role::kObserver), 1}, {protocol::EmergencyStop{}, 2}}));
  EXPECT_TRUE(std::holds_alternative<protocol::Welcome>(operator_.reply_to(1)));
  const auto ack = operator_.reply_to(2);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(ack)) << TestClient::describe(ack);
  const auto status = status_of(operator_);
  EXPECT_EQ(status.state, ProcedureState::kFault);
  EXPECT_EQ(status.latched_fault, ErrorCode::kEmergencyStopped);
  const WheelCounts rest = wait_at_rest(w, ProcedureState::kFault);
  EXPECT_TRUE(wheels_stay_put(w, rest));
  // One of the silent sockets made room (TOO_MANY_CLIENTS, closed); the controller is untouched.
  EXPECT_TRUE(eventually([&] {
    for (auto& s : silent)
      if (s->wait_closed(50ms)) return true;
    return false;
  }));
  EXPECT_TRUE(std::holds_alternative<protocol::Status>(controller.request(protocol::GetStatus{})));
}

// Reset (clearing a latched fault) + AlignBase + Stop in one write: the Stop cancels the queued
// move, nothing turns, and the fault stays cleared.
TEST_F(StopRaces, ResetAlignBaseAndStopInOneWriteTurnsNothing) {
  Watched robot(config(1.0));
  auto& [d, w, controller] = robot;
  measure_door(controller, 0.6);
  for (std::uint32_t round = 0; round < 5; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    ASSERT_TRUE(
        std::holds_alternative<protocol::Ack>(controller.request(protocol::EmergencyStop{})));
    ASSERT_EQ(status_of(controller).state, ProcedureState::kFault);
    const WheelCounts before = wait_at_rest(w);
    const std::uint32_t id = 200 + 3 * round;
    controller.send_raw(one_write(
        {{protocol::Reset{}, id}, {protocol::AlignBase{}, id + 1}, {protocol::Stop{}, id + 2}}));
    ASSERT_TRUE(std::holds_alternative<protocol::Ack>(controller.reply_to(id)));
    (void)controller.reply_to(id + 1);
    ASSERT_TRUE(std::holds_alternative<protocol::Ack>(controller.reply_to(id + 2)));
    ASSERT_TRUE(wheels_stay_put(w, before));
    const auto status = status_of(controller);
    EXPECT_NE(status.state, ProcedureState::kAligning);
    EXPECT_EQ(status.latched_fault, ErrorCode::kOk);
    ready_to_align(controller);
  }
}

// Two Resets in one write during a fault: both answered, and a fault the loop raises afterwards
// (the deadman of a controller that falls silent mid-alignment) is still latched.
TEST_F(StopRaces, TwoResetsInOneWriteLeaveLaterFaultsLatching) {
  Watched robot(config(1.0));
  auto& [d, w, controller] = robot;
  measure_door(controller, 0.6);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(controller.request(protocol::EmergencyStop{})));
  controller.send_raw(one_write({{protocol::Reset{}, 300}, {protocol::Reset{}, 301}}));
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(controller.reply_to(300)));
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(controller.reply_to(301)));
  // And two recoveries requested back to back (each Reset clears a fault) in one write.
  controller.send_raw(one_write({{protocol::EmergencyStop{}, 302},
                                 {protocol::Reset{}, 303},
                                 {protocol::EmergencyStop{}, 304},
                                 {protocol::Reset{}, 305}}));
  for (std::uint32_t id = 302; id <= 305; ++id) {
    const auto reply = controller.reply_to(id);
    ASSERT_TRUE(std::holds_alternative<protocol::Ack>(reply)) << id << TestClient::describe(reply);
  }
  ASSERT_EQ(status_of(controller).latched_fault, ErrorCode::kOk);
  w.events().clear();  // the e-stop's fault_latched is history
  // The card is back (the recovery finished): the move is accepted.
  protocol::Message align;
  ASSERT_TRUE(eventually([&] {
    align = controller.request(protocol::AlignBase{});
    return std::holds_alternative<protocol::Ack>(align);
  })) << TestClient::describe(align);
  // The controller now falls silent while the base turns: the loop's deadman must latch.
  bool deadman = false;
  while (!deadman) {  // (late e-stop fault_latched events are skipped)
    const auto e = w.wait_event(EventKind::kFaultLatched, 20s);
    if (!e) break;
    deadman = e->fault == ErrorCode::kDeadman;
  }
  EXPECT_TRUE(deadman);
  EXPECT_EQ(status_of(w).latched_fault, ErrorCode::kDeadman);
}

// An EmergencyStop from an observer while the controller's commands are being written to a slow
// disk (1.5 s per save, within SessionHub::kHeldReplyLimit): the e-stop is executed and
// acknowledged while that save is still running.
TEST_F(StopRaces, AnEmergencyStopDoesNotWaitForTheControllersSlowDisk) {
  InProcessDaemon d(slow_disk(1500));
  TestClient observer(d.port());
  observer.hello(Role::kObserver);
  TestClient controller(d.port());
  controller.hello(Role::kController);
  const std::uint32_t width_id = controller.send(good_width());
  ASSERT_TRUE(eventually([&] { return d.engine().accepted_generation() > 0; }));
  const std::uint64_t width_generation = d.engine().accepted_generation();
  const auto ack = observer.request(protocol::EmergencyStop{});
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(ack)) << TestClient::describe(ack);
  EXPECT_LT(d.engine().settled_generation(), width_generation)
      << "the e-stop Ack came only after the controller's save finished";
  EXPECT_EQ(status_of(observer).latched_fault, ErrorCode::kEmergencyStopped);
  // The controller's Ack arrives once its save is on disk, or once the held-reply limit (2 s) has
  // passed, whichever is first: a loaded ThreadSanitizer run took longer than 2 s for the 1.5 s
  // save, and the reply went out without waiting (logged). Either way the save completes.
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(controller.reply_to(width_id)));
  EXPECT_TRUE(eventually([&] { return d.engine().settled_generation() >= width_generation; }))
      << "the controller's save never finished";
}

// A disk that does not finish a save in time (4 s here) holds the controller's width Ack at most
// SessionHub::kHeldReplyLimit; its own Stop behind it is then acknowledged, in request order.
TEST_F(StopRaces, AHungDiskHoldsAnAckBoundedlyAndTheStopBehindItArrives) {
  InProcessDaemon d(slow_disk(4000));
  TestClient controller(d.port());
  controller.hello(Role::kController);
  controller.send_raw(one_write({{good_width(), 21}, {protocol::Stop{}, 22}}));
  const auto width = controller.reply_to(21, 3500ms);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(width)) << TestClient::describe(width);
  const auto stop = controller.reply_to(22, 1s);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(stop)) << TestClient::describe(stop);
  EXPECT_EQ(d.engine().settled_generation(), 0U) << "the save had not finished: the bound acted";
}

// One session's replies stay in request order when its first command waits for the disk.
TEST_F(StopRaces, DurableAcksKeepOneSessionsRequestOrder) {
  InProcessDaemon d(slow_disk(200));
  TestClient controller(d.port());
  controller.hello(Role::kController);
  controller.send_raw(one_write({{good_width(), 11},
                                 {protocol::Ping{5}, 12},
                                 {good_handle(), 13},
                                 {protocol::GetStatus{}, 14}}));
  std::vector<std::uint32_t> order;
  while (order.size() < 4) {
    auto outcome = controller.next();
    ASSERT_TRUE(outcome && outcome->kind == protocol::StreamDecoder::Kind::kMessage);
    if (outcome->envelope.request_id == 0) continue;  // events
    order.push_back(outcome->envelope.request_id);
    if (outcome->envelope.request_id == 11 || outcome->envelope.request_id == 13) {
      // Released only once durable.
      EXPECT_GE(d.engine().settled_generation(), outcome->envelope.request_id == 11 ? 1U : 2U);
    }
  }
  EXPECT_EQ(order, (std::vector<std::uint32_t>{11, 12, 13, 14}));
  EXPECT_EQ(status_of(controller).state, ProcedureState::kAwaitingPlane);
}

// ---- against the ajard binary
// --------------------------------------------------------------------

class AjardStopRaces : public EndToEndOnMock {
 protected:
  std::string state_file() const { return dir_.path() + "/state/ajard.state"; }
};

// A state file with a valid checksum but impossible content is not restored; it is kept beside the
// new file, the log says so, and STATE_REJECTED latches (issue 22).
TEST_F(AjardStopRaces, AnImpossibleStateFileIsRejectedKeptAndReported) {
  std::filesystem::create_directories(dir_.path() + "/state");
  const std::string impossible =
      with_checksum("ajar-state 1\nphase idle\naligned 0\nplane_consumed 0\nfault 65535\n");
  std::ofstream(state_file()) << impossible;
  const std::string port_file = dir_.path() + "/port";
  AjardProcess ajard({"--config", write_config(20.0), "--port-file", port_file}, dir_.path());
  const auto port = wait_for_port_file(port_file, ajard);
  ASSERT_TRUE(port) << ajard.err();
  TestClient observer(*port);
  observer.hello(Role::kObserver);
  const auto status = status_of(observer);
  EXPECT_FALSE(status.restored_from_disk);
  EXPECT_EQ(status.state, ProcedureState::kFault);
  EXPECT_EQ(status.latched_fault, ErrorCode::kStateRejected);
  std::string kept;
  for (const auto& entry : std::filesystem::directory_iterator(dir_.path() + "/state")) {
    if (entry.path().filename().string().starts_with("ajard.state.rejected-")) kept = entry.path();
  }
  ASSERT_FALSE(kept.empty());
  EXPECT_EQ(read_text_file(kept), impossible);
  EXPECT_TRUE(ajard.err_shows("fault code '65535'")) << ajard.err();
  EXPECT_TRUE(ajard.err_shows(kept)) << ajard.err();
  ajard.signal(SIGTERM);
  EXPECT_EQ(ajard.wait_exit(), 0);
}

// SIGTERM while the base turns: every session receives motion_stopped before it is closed.
TEST_F(AjardStopRaces,
       SigtermWhileMovingSendsMotionStoppedBeforeClosing) {  // (and its Engine::shutdown() emitting
                                                             // motion_stopped)
  const std::string port_file = dir_.path() + "/port";
  AjardProcess ajard({"--config", write_config(1.0), "--port-file", port_file}, dir_.path());
  const auto port = wait_for_port_file(port_file, ajard);
  ASSERT_TRUE(port) << ajard.err();
  TestClient observer(*port);
  observer.hello(Role::kObserver);
  TestClient controller(*port);
  controller.hello(Role::kController);
  measure_door(controller, 0.6);
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  ASSERT_TRUE(observer.wait_event(EventKind::kMotionStarted));
  ajard.signal(SIGTERM);
  EXPECT_TRUE(observer.wait_closed());
  EXPECT_TRUE(controller.wait_closed());
  bool stopped = false;
  for (const auto& e : observer.events())
    stopped = stopped || e.kind == EventKind::kMotionStopped;
  EXPECT_TRUE(stopped);
  EXPECT_EQ(ajard.wait_exit(), 0);
}

}  // namespace
}  // namespace ajar::test
