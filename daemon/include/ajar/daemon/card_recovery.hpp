// CardRecovery: the control loop's recovery of the motion card after a Reset (ControlLoop, step
// 3), a state machine advanced once per cycle: wait for the wheels to rest (a stop has its own
// deadline), clear the axes' faults, enable them, then poll their status every cycle until both
// servos are on without alarm or following error; fail when that has not happened within the
// recovery timeout (counted from the end of the wait). It makes no card call itself: next() says
// which call the loop makes now (noexcept, no allocation, no waiting, like the cycle). A failed
// card call or a fault ends the recovery through the loop's latch (end()).
#pragma once

#include <cstdint>

#include "ajar/core/error.hpp"
#include "ajar/drivers/motion_card.hpp"

namespace ajar::daemon {

class CardRecovery {
 public:
  struct Step {
    enum class Kind : std::uint8_t {
      kWait,         // nothing this cycle (the wheels still move, or the servos are not on yet)
      kClearFaults,  // call MotionCard::clear_faults now
      kEnableAxes,   // call MotionCard::enable_axes now
      kRecovered,    // both servos on, no alarm: the recovery succeeded
      kFault,        // latch `code` (on the wheel `axis_index`, -1: none); the recovery fails
    };
    Kind kind = Kind::kWait;
    ErrorCode code = ErrorCode::kOk;
    int axis_index = -1;  // 0 left, 1 right
  };

  explicit CardRecovery(std::int64_t timeout_ns) noexcept : timeout_ns_(timeout_ns) {}

  bool running() const noexcept { return phase_ != Phase::kNone; }
  // The sequence of the last recover request the loop took (answered with it).
  std::uint32_t sequence() const noexcept { return sequence_; }

  // A recover request the loop takes: answered at once (take) or run (begin).
  void take(std::uint32_t sequence) noexcept { sequence_ = sequence; }
  void begin(std::uint32_t sequence) noexcept {
    sequence_ = sequence;
    phase_ = Phase::kWaitRest;
  }
  void end() noexcept { phase_ = Phase::kNone; }

  // This cycle's step; `wheels_idle`: no motion runs; `answered`/`status`: this cycle's reading.
  Step next(std::int64_t now_ns, bool wheels_idle, bool answered,
            const drivers::AxisStatus (&status)[2]) noexcept;

 private:
  enum class Phase : std::uint8_t { kNone, kWaitRest, kClear, kEnable, kPoll };

  std::int64_t timeout_ns_;
  Phase phase_ = Phase::kNone;
  std::uint32_t sequence_ = 0;
  std::int64_t deadline_ns_ = 0;
};

}  // namespace ajar::daemon
