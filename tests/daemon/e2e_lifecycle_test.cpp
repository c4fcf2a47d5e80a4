// Issue 22, items 4-6, against the ajard binary on mock drivers, each as it was reproduced:
//  4. an EmergencyStop during the SIGTERM shutdown is executed, acknowledged and latched, and still
//     latched after the restart; other requests get SHUTTING_DOWN; a disk that never finishes does
//     not hold the exit;
//  5. a fault latched before a state file is rejected stays latched (or STATE_REJECTED latches);
//  6. a kill right after an acknowledged EmergencyStop — or any unclean end — comes back with a
//     latched fault (UNCLEAN_SHUTDOWN) that only a Reset clears.
// No timing is asserted: every wait is bounded and checks an outcome.
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "ajard_restarts.hpp"
#include "e2e_fixture.hpp"
#include "state_file_checksum.hpp"

namespace ajar::test {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;
using protocol::Role;

class AjardLifecycle : public EndToEndOnMock {
 protected:
  std::string path(const std::string& name) const { return dir_.path() + "/" + name; }
  std::string state_dir() const { return dir_.path() + "/state"; }
  std::string write(const daemon::Config& c, const std::string& name = "ajard.yaml") {
    std::ofstream(path(name)) << daemon::to_yaml(c);
    return path(name);
  }
  std::optional<std::uint16_t> start(const std::string& config, const std::string& name) {
    return start_ajard(ajard_, config, dir_.path(), name);
  }
  static protocol::Status status_of(TestClient& client) {
    return client.request_as<protocol::Status>(protocol::GetStatus{});
  }
  bool saw_fault(TestClient& client, ErrorCode code) {
    for (const auto& e : client.events())
      if (e.kind == EventKind::kFaultLatched && e.fault == code) return true;
    return false;
  }
  // After a restart: `fault` is latched, a Drive is refused and nothing moves; then a Reset
  // clears it and a Drive is accepted again.
  void expect_latched_until_reset(std::uint16_t port, const std::vector<ErrorCode>& allowed) {
    TestClient watcher(port);
    watcher.hello(Role::kObserver);
    const auto status = status_of(watcher);
    EXPECT_EQ(status.state, ProcedureState::kFault);
    EXPECT_NE(std::find(allowed.begin(), allowed.end(), status.latched_fault), allowed.end())
        << "latched: " << to_string(status.latched_fault);
    watcher.request_as<protocol::Ack>(protocol::Subscribe{100});
    TestClient controller(port);
    controller.hello(Role::kController);
    EXPECT_EQ(error_code_of(controller.request(protocol::Drive{0.1, 0.0})),
              ErrorCode::kFaultLatched);
    EXPECT_TRUE(nothing_moves(watcher));
    EXPECT_TRUE(std::holds_alternative<protocol::Ack>(controller.request(protocol::Reset{})));
    EXPECT_TRUE(
        std::holds_alternative<protocol::Ack>(controller.request(protocol::Drive{0.1, 0.0})));
    controller.request(protocol::Stop{});
    // At rest before the controller leaves (else its leaving is a DEADMAN). A Telemetry frame
    // already on its way may predate the jog, so first the jog's end must have been reported:
    // its motion_stopped (or motion_finished) event, which the daemon sends once the loop has
    // ended the stop.
    const auto ended = [&controller] {
      for (const auto& e : controller.events())
        if (e.kind == protocol::EventKind::kMotionStopped ||
            e.kind == protocol::EventKind::kMotionFinished)
          return true;
      return false;
    };
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!ended() && std::chrono::steady_clock::now() < give_up) {
      controller.request(protocol::Ping{1});
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    EXPECT_TRUE(ended()) << "the jog's end was never reported";
    for (int frames = 0; frames < 1000; ++frames) {
      ASSERT_TRUE(watcher.wait_telemetry(watcher.telemetry_count() + 1));
      controller.request(protocol::Ping{1});
      if (!watcher.last_telemetry()->moving) break;
    }
    EXPECT_FALSE(watcher.last_telemetry()->moving);
  }

  std::unique_ptr<AjardProcess> ajard_;
};

// Item 4. SIGTERM while the base turns (a smooth stop that takes a while); the controller sees
// SHUTTING_DOWN for anything but a stop; an observer's EmergencyStop in that window gets its Ack,
// latches (fault_latched reaches the sessions before they close), and is latched after the restart.
TEST_F(AjardLifecycle, AnEmergencyStopDuringShutdownIsExecutedAcknowledgedAndStaysLatched) {
  auto c = config(1.0);
  c.base.max_wheel_speed_rad_s = 0.5;
  c.base.max_wheel_accel_rad_s2 = 0.25;  // a smooth stop from cruise takes more than a second
  const std::string file = write(c);
  const auto port = start(file, "first");
  ASSERT_TRUE(port) << ajard_->err();
  TestClient observer(*port);
  observer.hello(Role::kObserver);
  observer.request_as<protocol::Ack>(protocol::Subscribe{100});
  TestClient controller(*port);
  controller.hello(Role::kController);
  measure_door(controller, 0.6);
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  // Until the wheels cruise (the controller keeps talking: no deadman).
  for (;;) {
    ASSERT_TRUE(observer.wait_telemetry(observer.telemetry_count() + 1));
    controller.request(protocol::Ping{1});
    if (std::abs(observer.last_telemetry()->left_wheel_rad) > 0.3) break;
  }
  ajard_->signal(SIGTERM);
  // The shutdown has begun once a request is answered SHUTTING_DOWN (a Status before that).
  for (;;) {
    const auto reply = try_request(controller, protocol::GetStatus{});
    ASSERT_TRUE(reply) << "no reply during the shutdown (the I/O thread is blocked)";
    if (error_code_of(*reply) == ErrorCode::kShuttingDown) break;
    ASSERT_TRUE(std::holds_alternative<protocol::Status>(*reply));
  }
  const auto estop = try_request(observer, protocol::EmergencyStop{});
  ASSERT_TRUE(estop) << "the EmergencyStop got no reply during the shutdown";
  EXPECT_TRUE(is_ack(estop)) << TestClient::describe(*estop);
  EXPECT_EQ(refusal_of(try_request(controller, ajar::testing::good_width())),
            ErrorCode::kShuttingDown);
  EXPECT_TRUE(observer.wait_closed());
  EXPECT_TRUE(controller.wait_closed());
  observer.close();  // else the daemon waits (bounded) for the peers to close
  controller.close();
  EXPECT_TRUE(saw_fault(observer, ErrorCode::kEmergencyStopped));
  EXPECT_EQ(ajard_->wait_exit(), 0) << ajard_->err();

  const auto again = start(file, "second");
  ASSERT_TRUE(again) << ajard_->err();
  expect_latched_until_reset(*again, {ErrorCode::kEmergencyStopped});
}

// Item 4. The state writer hangs (a disk that never finishes) during the shutdown: ajard still
// exits, says the state was not persisted, and the next start treats it as an unclean end.
TEST_F(AjardLifecycle, AShutdownWithAHungDiskStillEndsAndTheRestartIsLatched) {
  const std::string file = write_config(20.0);
  const auto port = start(file, "first");
  ASSERT_TRUE(port) << ajard_->err();
  {
    TestClient controller(*port);
    controller.hello(Role::kController);
    measure_door(controller);
    ASSERT_TRUE(hang_disk(state_dir()));
    EXPECT_TRUE(is_ack(try_request(controller, protocol::EmergencyStop{})));
    ajard_->signal(SIGTERM);
    EXPECT_TRUE(controller.wait_closed());
    controller.close();
  }
  EXPECT_EQ(ajard_->wait_exit(), 0) << "the shutdown waited for the disk without a limit";
  EXPECT_NE(ajard_->err().find("not persisted"), std::string::npos) << ajard_->err();
  resume_disk(state_dir());
  const auto again = start(file, "second");
  ASSERT_TRUE(again) << ajard_->err();
  expect_latched_until_reset(*again, {ErrorCode::kEmergencyStopped, ErrorCode::kUncleanShutdown});
}

// Item 5. EmergencyStop, SIGTERM, a narrower limits.door_width_m, restart: the stored measurements
// no longer validate (the file is moved aside), but the fault stays latched.
TEST_F(AjardLifecycle, AFaultLatchedBeforeTheStateFileIsRejectedStaysLatched) {
  auto c = config(20.0);
  const auto port = start(write(c), "first");
  ASSERT_TRUE(port) << ajard_->err();
  {
    TestClient controller(*port);
    controller.hello(Role::kController);
    measure_door(controller);
    EXPECT_TRUE(is_ack(try_request(controller, protocol::EmergencyStop{})));
    ajard_->signal(SIGTERM);
    EXPECT_TRUE(controller.wait_closed());
    controller.close();
  }
  ASSERT_EQ(ajard_->wait_exit(), 0) << ajard_->err();
  c.limits.min_door_width_m = 0.9;  // the stored 0.85 m door is now out of range
  const auto again = start(write(c), "second");
  ASSERT_TRUE(again) << ajard_->err();
  {
    TestClient observer(*again);
    observer.hello(Role::kObserver);
    const auto status = status_of(observer);
    EXPECT_FALSE(status.restored_from_disk);
    EXPECT_FALSE(status.has_width);
  }
  EXPECT_TRUE(ajard_->err_shows("no longer validates")) << ajard_->err();
  expect_latched_until_reset(*again, {ErrorCode::kEmergencyStopped});
}

// Item 5. A state file that cannot be decoded: nothing of it can be trusted, not even whether it
// held a fault, so STATE_REJECTED latches until a Reset.
TEST_F(AjardLifecycle, AStateFileThatCannotBeDecodedLatchesStateRejected) {
  std::filesystem::create_directories(state_dir());
  std::ofstream(state_dir() + "/ajard.state") << "ajar-state 2\nphase idle\nfault 513\ncrc32 0\n";
  const auto port = start(write_config(20.0), "first");
  ASSERT_TRUE(port) << ajard_->err();
  expect_latched_until_reset(*port, {ErrorCode::kStateRejected});
}

// Item 6. The EmergencyStop's Ack does not wait for the disk; here the disk never finishes its
// save (what a kill -9 within a millisecond of the Ack sees, made certain), then kill -9. The
// restart comes back with a fault latched and the measurements restored; nothing moves until a
// Reset.
TEST_F(AjardLifecycle, AKillRightAfterAnAcknowledgedEmergencyStopComesBackLatched) {
  const std::string file = write_config(20.0);
  const auto port = start(file, "first");
  ASSERT_TRUE(port) << ajard_->err();
  {
    TestClient controller(*port);
    controller.hello(Role::kController);
    measure_door(controller);  // durable Acks: on disk
    ASSERT_TRUE(hang_disk(state_dir()));
    EXPECT_TRUE(is_ack(try_request(controller, protocol::EmergencyStop{})));
    ajard_->signal(SIGKILL);
  }
  EXPECT_EQ(ajard_->wait_exit(), 128 + SIGKILL);
  resume_disk(state_dir());
  const auto again = start(file, "second");
  ASSERT_TRUE(again) << ajard_->err();
  {
    TestClient observer(*again);
    observer.hello(Role::kObserver);
    const auto status = status_of(observer);
    EXPECT_TRUE(status.restored_from_disk);
    EXPECT_TRUE(status.has_width && status.has_handle && status.has_plane);
  }
  expect_latched_until_reset(*again, {ErrorCode::kEmergencyStopped, ErrorCode::kUncleanShutdown});
}

// Item 6. Any end without a clean shutdown — here kill -9 of an idle daemon, as a power loss —
// needs an operator's Reset before anything moves; a clean SIGTERM does not; nor does a first
// start without a state file.
TEST_F(AjardLifecycle, AStartAfterAnUncleanEndNeedsAResetAndACleanEndDoesNot) {
  const std::string file = write_config(20.0);
  auto port = start(file, "first");
  ASSERT_TRUE(port) << ajard_->err();
  {
    TestClient observer(*port);
    observer.hello(Role::kObserver);
    EXPECT_EQ(status_of(observer).latched_fault, ErrorCode::kOk);  // a first start
  }
  ajard_->signal(SIGKILL);
  EXPECT_EQ(ajard_->wait_exit(), 128 + SIGKILL);
  port = start(file, "second");
  ASSERT_TRUE(port) << ajard_->err();
  EXPECT_TRUE(ajard_->err_shows("UNCLEAN_SHUTDOWN")) << ajard_->err();
  expect_latched_until_reset(*port, {ErrorCode::kUncleanShutdown});
  ajard_->signal(SIGTERM);
  EXPECT_EQ(ajard_->wait_exit(), 0) << ajard_->err();
  port = start(file, "third");
  ASSERT_TRUE(port) << ajard_->err();
  TestClient observer(*port);
  observer.hello(Role::kObserver);
  EXPECT_EQ(status_of(observer).latched_fault, ErrorCode::kOk);
}

}  // namespace
}  // namespace ajar::test
