// Control surface of the GTS card simulator (libajar_gts_sim.so, drivers/cardsim). The simulator
// exports the vendor's GT_* calls (gts_abi.hpp) with the vendor's ABI and, besides them, these
// AjarSim_* C functions so that tests, the daemon (sim mode) and simulation runs can set the clock
// and inject faults. Load it with GtsSimControl (dlopen of the same file the driver loads: the
// dynamic loader hands both the same instance, so both see one simulated card).
//
// Simulated time (integer nanoseconds) = the monotonic clock scaled by the time scale, or a manual
// clock that only AjarSim_AdvanceClockNs moves; brought up to date on every call (no thread).
// Motion is evaluated in closed form at that time, so the call rate does not change a trajectory.
// All AjarSim_* and GT_* calls are serialised by one mutex inside the simulator (a hanging call
// waits before it takes it); none lets an exception out.
#pragma once

#include <string>

namespace ajar::drivers {

// AjarSim_InjectFault kinds.
enum class SimFault : int {
  kNone = 0,            // clears every injected fault on the axis (like GT_ClrSts)
  kDriveAlarm = 1,      // drive alarm: status 0x2, servo drops, motion stops at once
  kFollowingError = 2,  // status 0x10, encoder diverges from the profile, motion stops at once
  kPositiveLimit = 3,   // status 0x20; positive motion stops at once and is refused until cleared
  kNegativeLimit = 4,   // status 0x40; likewise for negative motion
};

extern "C" {
// Back to power-on: card closed, axes off at position 0, no faults, no failure rules, time scale
// 1, no call delay, encoder lag 1 ms, call counters zeroed, no hanging call.
using AjarSim_Reset_t = void (*)();
// Simulated time runs `scale` times faster than the monotonic clock (> 0).
using AjarSim_SetTimeScale_t = void (*)(double scale);
// manual != 0: simulated time stands still except through AjarSim_AdvanceClockNs (deterministic
// tests); 0: back to the scaled monotonic clock, continuing from the current simulated time.
using AjarSim_SetManualClock_t = void (*)(int manual);
// Manual clock only: moves simulated time forward by `ns` (> 0).
using AjarSim_AdvanceClockNs_t = void (*)(long long ns);
// Latches a fault on an axis (1..8); SimFault values.
using AjarSim_InjectFault_t = void (*)(short axis, int fault);
// The next `count` calls of `function` (e.g. "GT_GetSts"; nullptr or "*" = any GT_* call) return
// `code` without doing anything; count < 0 = until cleared; count 0 clears the rule.
using AjarSim_FailNextCalls_t = void (*)(const char* function, short code, int count);
// Every GT_* call sleeps this long (real time) before it runs: a slow card / bus.
using AjarSim_SetCallDelayUs_t = void (*)(int delay_us);
// A vendor call that hangs: the next call of `function` (nullptr or "*" = any GT_* call) waits,
// before it runs and outside the simulator's lock, for `block_ms` of real time, or until
// AjarSim_ReleaseBlockedCalls when block_ms < 0; then it runs as usual. Other calls (GT_Stop from
// another thread) go on meanwhile. One call per arming; arming again replaces the rule.
// The same from outside the process (an ajard running on the simulator): when the environment
// variable AJAR_SIM_BLOCK_FILE names a file (read once, at the first GT_* call), the next GT_* call
// made while that file exists hangs until it is removed (one call at a time; other threads' calls
// go on meanwhile).
using AjarSim_BlockNextCall_t = void (*)(const char* function, int block_ms);
// Ends every hanging call (also the file's) and clears the rule.
using AjarSim_ReleaseBlockedCalls_t = void (*)();
// How many calls hang right now.
using AjarSim_BlockedCalls_t = int (*)();
// Encoder lags the profile by this much simulated time while moving (0 = none).
using AjarSim_SetEncoderLagMs_t = void (*)(double lag_ms);
// How often `function` was called since the last reset (nullptr or "*" = all GT_* calls).
using AjarSim_CallCount_t = int (*)(const char* function);
// The axis mask of the last GT_Update, and the mask and option of the last GT_Stop.
using AjarSim_LastUpdateMask_t = long (*)();
using AjarSim_LastStop_t = void (*)(long* mask, long* option);
// Simulated time since reset, ms.
using AjarSim_NowMs_t = double (*)();
}

// Opens the simulator library (dlopen) and resolves the AjarSim_* functions. Throws
// DriverStartupError naming the path or the missing symbol.
class GtsSimControl {
 public:
  explicit GtsSimControl(const std::string& library_path);
  ~GtsSimControl();
  GtsSimControl(const GtsSimControl&) = delete;
  GtsSimControl& operator=(const GtsSimControl&) = delete;

  AjarSim_Reset_t reset = nullptr;
  AjarSim_SetTimeScale_t set_time_scale = nullptr;
  AjarSim_SetManualClock_t set_manual_clock = nullptr;
  AjarSim_AdvanceClockNs_t advance_clock_ns = nullptr;
  AjarSim_InjectFault_t inject_fault_raw = nullptr;
  AjarSim_FailNextCalls_t fail_next_calls = nullptr;
  AjarSim_SetCallDelayUs_t set_call_delay_us = nullptr;
  AjarSim_BlockNextCall_t block_next_call = nullptr;
  AjarSim_ReleaseBlockedCalls_t release_blocked_calls = nullptr;
  AjarSim_BlockedCalls_t blocked_calls = nullptr;
  AjarSim_SetEncoderLagMs_t set_encoder_lag_ms = nullptr;
  AjarSim_CallCount_t call_count = nullptr;
  AjarSim_LastUpdateMask_t last_update_mask = nullptr;
  AjarSim_LastStop_t last_stop = nullptr;
  AjarSim_NowMs_t now_ms = nullptr;

  void inject_fault(int axis, SimFault fault) const;

 private:
  void* handle_ = nullptr;
};

// The card simulator library for drivers.kind sim with an empty drivers.card.library_path: the
// installed one (LIBDIR/ajar/libajar_gts_sim.so, found relative to the running ajard, so an install
// tree may be moved), else the one built with this tree (development); if neither exists, the
// installed path (start-up then fails naming it).
std::string default_card_simulator_path();

}  // namespace ajar::drivers
