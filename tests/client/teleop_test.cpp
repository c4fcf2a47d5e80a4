// ajarctl drive without a terminal: the key decoder, the velocity steps and limits, the Drive
// re-send schedule (time is passed in: no clock is read, nothing waits) and the status line.
#include <gtest/gtest.h>

#include "ajar/client/teleop.hpp"

namespace ajar::client::teleop {
namespace {

using namespace std::chrono_literals;

std::vector<Key> keys_of(std::string_view bytes) {
  KeyDecoder d;
  std::vector<Key> out;
  d.feed(std::span<const char>(bytes.data(), bytes.size()), out);
  d.idle(out);
  return out;
}

TEST(KeyDecoder, ArrowsWasdSpaceAndTheWaysOut) {
  EXPECT_EQ(keys_of("\x1b[A\x1b[B\x1b[C\x1b[D"),
            (std::vector<Key>{Key::kForward, Key::kBackward, Key::kRight, Key::kLeft}));
  EXPECT_EQ(keys_of("\x1bOA\x1bOD"), (std::vector<Key>{Key::kForward, Key::kLeft}));
  EXPECT_EQ(keys_of("wasdWASD"),
            (std::vector<Key>{Key::kForward, Key::kLeft, Key::kBackward, Key::kRight, Key::kForward,
                              Key::kLeft, Key::kBackward, Key::kRight}));
  EXPECT_EQ(keys_of(" "), std::vector<Key>{Key::kStop});
  EXPECT_EQ(keys_of("q"), std::vector<Key>{Key::kQuit});
  EXPECT_EQ(keys_of("\x03"), std::vector<Key>{Key::kQuit});  // Ctrl-C in raw mode
  EXPECT_EQ(keys_of("\x04"), std::vector<Key>{Key::kQuit});  // Ctrl-D
  EXPECT_TRUE(keys_of("xyz1\n").empty());
}

TEST(KeyDecoder, ALoneEscIsQuitOnlyWhenNothingFollows) {
  KeyDecoder d;
  std::vector<Key> out;
  d.feed(std::span<const char>("\x1b", 1), out);
  EXPECT_TRUE(out.empty()) << "an ESC may start an arrow: held";
  d.feed(std::span<const char>("[", 1), out);  // arrow split over two reads
  d.feed(std::span<const char>("A", 1), out);
  EXPECT_EQ(out, std::vector<Key>{Key::kForward});
  out.clear();
  d.feed(std::span<const char>("\x1b", 1), out);
  d.idle(out);
  EXPECT_EQ(out, std::vector<Key>{Key::kQuit});
  out.clear();
  d.feed(std::span<const char>("\x1bw", 2), out);  // Esc then w
  EXPECT_EQ(out, (std::vector<Key>{Key::kQuit, Key::kForward}));
  out.clear();
  d.feed(std::span<const char>("\x1b[15~w", 6), out);  // F5 is ignored, then w
  EXPECT_EQ(out, std::vector<Key>{Key::kForward});
}

TEST(Velocity, StepsAreClampedToTheRobotModelAndReturnToAnExactStop) {
  protocol::RobotModel model;
  model.max_linear_speed_m_s = 0.4;
  model.max_angular_speed_rad_s = 0.8;
  const Limits l = limits_from(model);
  EXPECT_DOUBLE_EQ(l.linear_step_m_s, 0.04);
  EXPECT_DOUBLE_EQ(l.angular_step_rad_s, 0.08);
  Velocity v;
  for (int i = 0; i < 25; ++i)
    apply(Key::kForward, v, l);
  EXPECT_DOUBLE_EQ(v.linear_m_s, 0.4);
  EXPECT_EQ(apply(Key::kForward, v, l), Action::kUnchanged) << "at the limit";
  for (int i = 0; i < 10; ++i)
    apply(Key::kBackward, v, l);
  EXPECT_EQ(v.linear_m_s, 0.0) << "ten steps back from the limit is exactly 0";
  for (int i = 0; i < 25; ++i)
    apply(Key::kRight, v, l);
  EXPECT_DOUBLE_EQ(v.angular_rad_s, -0.8) << "right turns clockwise (negative)";
  apply(Key::kLeft, v, l);
  EXPECT_GT(v.angular_rad_s, -0.8);
  EXPECT_EQ(apply(Key::kStop, v, l), Action::kStop);
  EXPECT_TRUE(v.zero());
  apply(Key::kForward, v, l);
  EXPECT_EQ(apply(Key::kQuit, v, l), Action::kQuit);
  EXPECT_TRUE(v.zero()) << "leaving stops";
}

TEST(Velocity, AModelWithoutDriveLimitsFallsBackToSafeDefaults) {
  const Limits l = limits_from(protocol::RobotModel{});
  EXPECT_DOUBLE_EQ(l.max_linear_m_s, 0.3);
  EXPECT_DOUBLE_EQ(l.max_angular_rad_s, 0.5);
  EXPECT_GT(l.linear_step_m_s, 0);
}

TEST(ResendScheduler, ResendsWhileMovingAndSendsTheStopOnce) {
  using Clock = ResendScheduler::Clock;
  const Clock::time_point t0{};  // a fake clock: only differences matter
  ResendScheduler s(100ms);
  Velocity v;
  EXPECT_FALSE(s.due(v, t0)) << "nothing until a key";
  EXPECT_EQ(s.next(v, t0), Clock::time_point::max());
  v.linear_m_s = 0.1;
  s.changed();
  EXPECT_EQ(s.next(v, t0), t0) << "pending: now";
  EXPECT_TRUE(s.due(v, t0)) << "a change is sent at once";
  EXPECT_FALSE(s.due(v, t0 + 50ms));
  EXPECT_EQ(s.next(v, t0 + 50ms), t0 + 100ms);
  EXPECT_TRUE(s.due(v, t0 + 100ms));
  EXPECT_FALSE(s.due(v, t0 + 150ms));
  EXPECT_TRUE(s.due(v, t0 + 230ms)) << "late: sent, and the next one counts from now";
  EXPECT_EQ(s.next(v, t0 + 230ms), t0 + 330ms);
  v.angular_rad_s = 0.2;
  s.changed();
  EXPECT_TRUE(s.due(v, t0 + 240ms)) << "a change does not wait for the period";
  v = {};
  s.changed();
  EXPECT_TRUE(s.due(v, t0 + 250ms)) << "the Drive{0, 0}";
  EXPECT_FALSE(s.due(v, t0 + 400ms)) << "zero is not re-sent";
  EXPECT_FALSE(s.due(v, t0 + 10s));
  EXPECT_EQ(s.next(v, t0 + 10s), Clock::time_point::max());
}

TEST(ResendScheduler, PeriodIsAThirdOfTheCommandTimeoutOrATenthOfASecond) {
  EXPECT_EQ(resend_period(0.6), std::chrono::nanoseconds(200'000'000));
  EXPECT_EQ(resend_period(0.0), std::chrono::nanoseconds(100'000'000));
  EXPECT_EQ(resend_period(-1.0), std::chrono::nanoseconds(100'000'000));
  EXPECT_EQ(resend_period(1e-9), std::chrono::nanoseconds(10'000'000)) << "floor: no flooding";
}

TEST(StatusLine, ShowsSetAndCommandedSpeedAndTheDoorWhenKnown) {
  Velocity v{0.1, -0.05};
  EXPECT_EQ(status_line(v, nullptr, ""), "set +0.100 m/s -0.050 rad/s");
  protocol::Telemetry t;
  t.commanded_linear_m_s = 0.08;
  t.moving = true;
  std::string line = status_line(v, &t, "");
  EXPECT_NE(line.find("commanded +0.080 m/s"), std::string::npos) << line;
  EXPECT_NE(line.find("door unknown"), std::string::npos) << line;
  t.door.has_distance = true;
  t.door.distance_m = 0.987;
  t.door.has_yaw = true;
  t.door.yaw_rad = 0.01;
  t.staleness.plane = true;
  line = status_line(v, &t, "refused");
  EXPECT_NE(line.find("door 0.987 m yaw +0.57 deg"), std::string::npos) << line;
  EXPECT_NE(line.find("plane STALE"), std::string::npos) << line;
  EXPECT_NE(line.find("| refused"), std::string::npos) << line;
}

}  // namespace
}  // namespace ajar::client::teleop
