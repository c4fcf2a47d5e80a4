// ajarctl drive --for, approach and the conformance suite's refusal to move a real robot, against
// the in-test fake daemon (tests/client/fake_daemon.hpp). Waits are bounded; no timing is asserted.
#include <atomic>
#include <filesystem>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "ajar/client/cli.hpp"
#include "ajar/conformance/conformance.hpp"
#include "fake_daemon.hpp"

namespace ajar::client {
namespace {

using fake::FakeDaemon;
using fake::polite;
using protocol::MessageType;

struct RunResult {
  int code;
  std::string out;
  std::string err;
};

RunResult ajarctl(const FakeDaemon& daemon, std::vector<std::string> args) {
  args.insert(args.begin(), {"--connect", "127.0.0.1:" + std::to_string(daemon.port())});
  std::istringstream in;
  std::ostringstream out, err;
  const int code = run_ajarctl(args, in, out, err);
  return RunResult{code, out.str(), err.str()};
}

protocol::Envelope refusal(const protocol::Envelope& e, ErrorCode code, const char* message) {
  protocol::ErrorReply r;
  r.code = code;
  r.offending_type = protocol::type_of(e.message);
  r.message = message;
  return {e.request_id, 0, r};
}

TEST(MotionRefusal, OnlyRealOrUnsaidDriversAreRefusedUnlessAllowed) {
  using conformance::motion_refusal;
  using protocol::DriverKind;
  EXPECT_EQ(motion_refusal(DriverKind::kSim, false), "");
  EXPECT_EQ(motion_refusal(DriverKind::kMock, false), "");
  const std::string real = motion_refusal(DriverKind::kReal, false);
  EXPECT_NE(real.find("real"), std::string::npos) << real;
  EXPECT_NE(real.find("--allow-motion-on-real-robot"), std::string::npos) << real;
  EXPECT_EQ(motion_refusal(DriverKind::kReal, true), "");
  // A 1.0 daemon does not say which drivers it runs: treated as possibly real.
  EXPECT_NE(motion_refusal(std::nullopt, false), "");
  EXPECT_EQ(motion_refusal(std::nullopt, true), "");
}

// A daemon that claims the real robot: conformance runs, but nothing that moves the base or the
// arm is sent by a controller session, and the output says why.
TEST(Conformance, AgainstARealRobotNoControllerSendsAMotion) {
  FakeDaemon daemon([](const protocol::Envelope& e) -> std::vector<protocol::Envelope> {
    if (const auto* hello = std::get_if<protocol::Hello>(&e.message)) {
      protocol::Welcome w;
      w.granted_role = hello->requested_role;
      w.deadman_timeout_s = 0.5f;
      w.driver_kind = protocol::DriverKind::kReal;
      return {{e.request_id, 0, w}};
    }
    return polite(e);
  });
  const auto empty =
      std::filesystem::temp_directory_path() / ("ajar-no-vectors-" + std::to_string(daemon.port()));
  std::filesystem::create_directories(empty);
  const RunResult r =
      ajarctl(daemon, {"--timeout", "0.2", "conformance", "--vectors", empty.string()});
  std::filesystem::remove_all(empty);
  EXPECT_NE(r.out.find("REFUSED motion checks: the daemon drives the real robot"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("SKIP faults: the controller leaving during motion"), std::string::npos)
      << r.out;
  const auto got = daemon.received();
  const auto on = daemon.received_on();
  std::map<std::size_t, protocol::Role> role;
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (const auto* hello = std::get_if<protocol::Hello>(&got[i].message)) {
      role.emplace(on[i], hello->requested_role);
    }
  }
  std::size_t controllers = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto type = protocol::type_of(got[i].message);
    const bool controller = role.count(on[i]) && role[on[i]] == protocol::Role::kController;
    if (controller) ++controllers;
    const bool moves = type == MessageType::kAlignBase || type == MessageType::kEngage ||
                       type == MessageType::kDrive || type == MessageType::kApproach;
    EXPECT_FALSE(controller && moves)
        << protocol::to_string(type) << " sent by a controller to a real robot";
  }
  EXPECT_GT(controllers, 0u) << "the other checks still ran";
}

TEST(Drive, ARefusalExitsOneWithTheDaemonsSentenceAndSendsAStop) {
  FakeDaemon daemon([](const protocol::Envelope& e) -> std::vector<protocol::Envelope> {
    if (std::holds_alternative<protocol::Drive>(e.message)) {
      return {refusal(e, ErrorCode::kNotSupported, "Drive: this daemon does not drive the base")};
    }
    return polite(e);
  });
  const RunResult r = ajarctl(daemon, {"drive", "--linear", "0.1", "--for", "5"});
  EXPECT_EQ(r.code, kExitRefused);
  EXPECT_NE(r.out.find("NOT_SUPPORTED: Drive: this daemon does not drive the base"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(daemon.count(MessageType::kDrive), 1u) << "no re-send after a refusal";
  EXPECT_GE(daemon.count(MessageType::kStop), 1u);
}

TEST(Drive, ForSecondsResendsThenDrivesZeroWaitsForRestAndPrintsTheOdometry) {
  std::atomic<int> statuses{0};
  FakeDaemon daemon([&](const protocol::Envelope& e) -> std::vector<protocol::Envelope> {
    if (const auto* d = std::get_if<protocol::Drive>(&e.message)) {
      std::vector<protocol::Envelope> out{
          {e.request_id, 0,
           protocol::Ack{MessageType::kDrive, protocol::ProcedureState::kAwaitingWidth,
                         protocol::EmptyAck{}}}};
      protocol::Telemetry t;
      t.moving = d->linear_m_s != 0;
      out.push_back({0, 0, t});
      return out;
    }
    if (std::holds_alternative<protocol::GetRobotModel>(e.message)) {
      protocol::RobotModel m;
      m.drive_command_timeout_s = 0.15;  // re-send every 50 ms
      return {{e.request_id, 0, m}};
    }
    if (std::holds_alternative<protocol::GetStatus>(e.message)) {
      protocol::Status s;
      s.odometry_x_m = statuses++ == 0 ? 0.0 : 0.05;
      return {{e.request_id, 0, s}};
    }
    return polite(e);
  });
  const RunResult r = ajarctl(daemon, {"drive", "--linear", "0.1", "--for", "0.3"});
  EXPECT_EQ(r.code, kExitOk) << r.out << r.err;
  std::vector<protocol::Drive> drives;
  for (const auto& e : daemon.received())
    if (const auto* d = std::get_if<protocol::Drive>(&e.message)) drives.push_back(*d);
  ASSERT_GE(drives.size(), 3u) << "at least two Drives at the velocity, then the zero";
  for (std::size_t i = 0; i + 1 < drives.size(); ++i)
    EXPECT_EQ(drives[i].linear_m_s, 0.1);
  EXPECT_EQ(drives.back().linear_m_s, 0.0);
  EXPECT_EQ(drives.back().angular_rad_s, 0.0);
  EXPECT_NE(r.out.find("odometry before: x +0.0000 m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("odometry after:  x +0.0500 m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("moved 0.0500 m"), std::string::npos) << r.out;
}

std::vector<protocol::Envelope> approach_daemon(const protocol::Envelope& e,
                                                protocol::EventKind end) {
  if (std::holds_alternative<protocol::Approach>(e.message)) {
    protocol::Ack ack{MessageType::kApproach, protocol::ProcedureState::kAwaitingHandle,
                      protocol::ApproachAck{0.25, 1.0, 1000, -1000}};
    protocol::Event done;
    done.kind = end;
    done.state = protocol::ProcedureState::kAwaitingHandle;
    return {{e.request_id, 0, ack}, {0, 0, done}};
  }
  if (std::holds_alternative<protocol::GetStatus>(e.message)) {
    protocol::Status s;
    s.door.has_distance = true;
    s.door.distance_m = 0.7501;
    return {{e.request_id, 0, s}};
  }
  return polite(e);
}

TEST(Approach, PrintsTheMoveWaitsForMotionFinishedAndReportsTheDistance) {
  FakeDaemon daemon([](const protocol::Envelope& e) {
    return approach_daemon(e, protocol::EventKind::kMotionFinished);
  });
  const RunResult r = ajarctl(daemon, {"approach", "0.75", "--wait-timeout", "20"});
  EXPECT_EQ(r.code, kExitOk) << r.out << r.err;
  EXPECT_NE(r.out.find("travel:        +0.2500 m (door now 1.0000 m away)"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("approach: done (motion_finished), door 0.7501 m"), std::string::npos)
      << r.out;
  EXPECT_EQ(std::get<protocol::Approach>(daemon.received()[1].message).standoff_m, 0.75);
}

TEST(Approach, AStoppedMoveIsAFailure) {
  FakeDaemon daemon([](const protocol::Envelope& e) {
    return approach_daemon(e, protocol::EventKind::kMotionStopped);
  });
  const RunResult r = ajarctl(daemon, {"--json", "approach", "0.75", "--wait-timeout", "20"});
  EXPECT_EQ(r.code, kExitRefused) << r.out;
  EXPECT_NE(r.out.find("\"type\":\"approach_result\",\"command\":\"approach\",\"ok\":false,"
                       "\"outcome\":\"motion_stopped\""),
            std::string::npos)
      << r.out;
}

}  // namespace
}  // namespace ajar::client
