// The card's recovery after a Reset (ajar/daemon/card_recovery.hpp).
#include "ajar/daemon/card_recovery.hpp"

namespace ajar::daemon {

CardRecovery::Step CardRecovery::next(std::int64_t now_ns, bool wheels_idle, bool answered,
                                      const drivers::AxisStatus (&status)[2]) noexcept {
  using Kind = Step::Kind;
  if (phase_ != Phase::kWaitRest && now_ns > deadline_ns_) {
    return {Kind::kFault, ErrorCode::kMotionTimeout, -1};  // the servo did not come on in time
  }
  switch (phase_) {
    case Phase::kNone:
      return {};
    case Phase::kWaitRest:  // the wheels come to rest first (a stop has its own deadline)
      if (!wheels_idle) return {};
      deadline_ns_ = now_ns + timeout_ns_;
      [[fallthrough]];
    case Phase::kClear:
      phase_ = Phase::kEnable;  // a refused call latches, which ends the recovery
      return {Kind::kClearFaults};
    case Phase::kEnable:
      phase_ = Phase::kPoll;
      return {Kind::kEnableAxes};
    case Phase::kPoll:
      if (!answered) return {};  // not answering: keep polling until the deadline
      for (int i = 0; i < 2; ++i) {
        if (status[i].alarm) return {Kind::kFault, ErrorCode::kAxisAlarm, i};
        if (status[i].following_error) return {Kind::kFault, ErrorCode::kFollowingError, i};
        if (!status[i].enabled) return {};
      }
      return {Kind::kRecovered};
  }
  return {};
}

}  // namespace ajar::daemon
