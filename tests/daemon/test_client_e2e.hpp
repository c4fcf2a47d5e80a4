// End-to-end test support: the shipped config (config/ajard.yaml) adapted for a test (drivers,
// state directory, port 0), and the door procedure driven through a TestClient.
#pragma once

#include <string>

#include "ajar/daemon/config.hpp"
#include "fake_door.hpp"
#include "test_client.hpp"

namespace ajar::test {

using ajar::testing::base_point;
using ajar::testing::collinear_plane;
using ajar::testing::good_contact;
using ajar::testing::good_handle;
using ajar::testing::good_width;
using ajar::testing::plane_at_yaw;
using ajar::testing::TempDir;
using ajar::testing::too_wide;
using ajar::testing::unreachable_contact;

// config/ajard.yaml with the test's drivers and state directory; the test door's points are given
// in the base frame, the camera looks straight ahead (as in the engine tests).
inline daemon::Config e2e_config(drivers::DriverKind kind, const std::string& dir,
                                 double speedup = 10.0) {
  daemon::Config c = daemon::load_config(AJAR_SOURCE_DIR "/config/ajard.yaml");
  c.drivers.kind = kind;
  c.drivers.sim_speedup = speedup;
  c.camera_to_base_m = ajar::testing::forward_camera_to_base_m();
  c.state.directory = dir + "/state";
  c.recorder.directory = dir + "/recordings";  // the black box records every e2e run
  c.network.bind_address = "127.0.0.1";
  c.network.port = 0;
  c.logging.sink = daemon::LogSink::kStderr;
  // The loop supervisor at its largest timeout (0.5 s, as the config allows): on a loaded CI host
  // (sanitizers, a build beside the tests) a loop thread starved for 108 ms latched LOOP_STALLED in
  // a test about something else (EndToEndCardLimits under ASan) — a wait for a CPU the supervisor
  // could not see until it ended (fixed since, docs/control-loop.md); the margin stays for what a
  // guest cannot see (its vCPU taken by the hypervisor). The stall tests hang a card call for
  // good, which any timeout catches; the supervisor's own timing is tested on a fake clock.
  c.control.stall_timeout_s = 0.5;
  return c;
}

inline const char* kind_name(drivers::DriverKind kind) {
  switch (kind) {
    case drivers::DriverKind::kMock:
      return "mock";
    case drivers::DriverKind::kSim:
      return "sim";
    default:
      return "real";
  }
}

// Polls GetStatus (a heartbeat when sent by the controller) until the state is reached or a fault
// latches. Returns the last status.
inline protocol::Status wait_for_state(
    TestClient& client, protocol::ProcedureState state,
    std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  protocol::Status status;
  while (std::chrono::steady_clock::now() < deadline) {
    status = client.request_as<protocol::Status>(protocol::GetStatus{});
    if (status.state == state) return status;
    if (status.state == protocol::ProcedureState::kFault &&
        state != protocol::ProcedureState::kFault) {
      ADD_FAILURE() << "fault latched: " << to_string(status.latched_fault);
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ADD_FAILURE() << "state " << protocol::to_string(state) << " not reached; still "
                << protocol::to_string(status.state);
  return status;
}

inline protocol::ProcedureState ack_state(const protocol::Message& reply) {
  const auto* ack = std::get_if<protocol::Ack>(&reply);
  if (ack == nullptr) {
    ADD_FAILURE() << "refused:" << TestClient::describe(reply);
    return protocol::ProcedureState::kFault;
  }
  return ack->state;
}

// Width, handle, plane: the parameters before any motion.
inline void measure_door(TestClient& controller, double yaw_rad = 0.1) {
  ASSERT_EQ(ack_state(controller.request(good_width())), protocol::ProcedureState::kAwaitingHandle);
  ASSERT_EQ(ack_state(controller.request(good_handle())), protocol::ProcedureState::kAwaitingPlane);
  ASSERT_EQ(ack_state(controller.request(plane_at_yaw(yaw_rad))),
            protocol::ProcedureState::kReadyToAlign);
}

// The whole procedure, from nothing measured to the arm engaged.
inline void run_procedure(TestClient& controller) {
  measure_door(controller);
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})),
            protocol::ProcedureState::kAligning);
  ASSERT_EQ(wait_for_state(controller, protocol::ProcedureState::kAligned).state,
            protocol::ProcedureState::kAligned);
  ASSERT_EQ(ack_state(controller.request(good_contact())),
            protocol::ProcedureState::kReadyToEngage);
  ASSERT_EQ(ack_state(controller.request(protocol::Engage{})), protocol::ProcedureState::kEngaging);
  ASSERT_EQ(wait_for_state(controller, protocol::ProcedureState::kEngaged).state,
            protocol::ProcedureState::kEngaged);
}

}  // namespace ajar::test
