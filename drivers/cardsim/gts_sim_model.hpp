// The simulated GTS card inside libajar_gts_sim.so: its axes, its clock, the failure rules and call
// counters the AjarSim_* controls set and read, and the two wrappers every exported function runs
// in. The vendor's calls are in gts_sim_vendor.cpp, the controls (gts_sim_control.hpp) in
// gts_sim_controls.cpp. One card with gts::kMaxAxes axes.
//
// Model (simulated time in integer nanoseconds = the monotonic clock x time scale, or a manual
// clock; brought up to date on each call, no thread):
// - Motion is closed form (ajar/drivers/motion_profile.hpp): a profile is planned when it starts
//   and evaluated exactly at the simulated time of each call, so any call rate sees the same
//   trajectory and a time jump costs O(1) under the lock.
// - GT_AxisOn: servo on 5 ms later (not while a drive alarm is latched).
// - GT_PrfTrap / GT_PrfJog select the axis' profile mode (refused, 1, while the axis moves in the
//   other mode). GT_SetVel: trap mode > 0; jog mode signed (the sign is the direction).
// - GT_Update starts the axes in the mask together: trap = trapezoid to GT_SetPos's target; jog =
//   ramp to GT_SetVel's velocity at the jog acc/dec and hold it. Refused (1) for an axis with no
//   profile mode, servo off, alarmed, following error, emergency-stopped, or moving into an active
//   limit.
// - GT_Stop: option bit set = emergency stop (halt at once, 0x100 latched until GT_ClrSts, blocks
//   GT_Update); clear = smooth stop along the mode's deceleration (0x80, cleared by the next
//   GT_Update).
// - Encoder = profile position delayed by the encoder lag while moving; equal at rest.
// - Faults: drive alarm (servo off, halt), following error (halt, encoder offset), limits (halt
//   when moving into them). GT_ClrSts clears all latched bits.
// No exported function lets an exception out: a GT_* call that fails inside returns 1 (execution
// error), an AjarSim_* control does nothing (or returns -1 where it returns a number).
// A hanging call (AjarSim_BlockNextCall, or the file named by AJAR_SIM_BLOCK_FILE) waits before it
// takes the simulator's lock: the other calls, GT_Stop from another thread included, go on.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "ajar/drivers/gts_abi.hpp"
#include "ajar/drivers/motion_profile.hpp"

#define AJAR_SIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace ajar::drivers::cardsim {

using Clock = std::chrono::steady_clock;

constexpr int kAxes = gts::kMaxAxes;
constexpr std::int64_t kNsPerMs = 1'000'000;

// The GT_* calls, for call counting and failure rules without allocation.
inline constexpr std::array<const char*, 18> kFunctions = {
    "GT_Open",    "GT_Close",   "GT_Reset",      "GT_LoadConfig", "GT_ClrSts",    "GT_AxisOn",
    "GT_AxisOff", "GT_PrfTrap", "GT_SetTrapPrm", "GT_PrfJog",     "GT_SetJogPrm", "GT_SetPos",
    "GT_SetVel",  "GT_Update",  "GT_GetSts",     "GT_GetPrfPos",  "GT_GetEncPos", "GT_Stop"};
// The index of `name` in kFunctions; -1 when it is none of them.
int function_index(const char* name);

enum class Mode : std::uint8_t { kNone, kTrap, kJog };

struct Axis {
  bool servo = false;
  std::int64_t servo_on_at_ns = -1;  // >= 0: servo comes on at this simulated time
  bool alarm = false, following_error = false, positive_limit = false, negative_limit = false;
  bool smooth_stopped = false, emergency_stopped = false;
  Mode mode = Mode::kNone;
  gts::TTrapPrm trap{0.1, 0.1, 0.0, 0};
  gts::TJogPrm jog{0.1, 0.1, 0.0};
  long target = 0;
  double vel_cmd = 0;
  // Motion: `motion` runs while `moving`; pos/vel are its last sample (the rest position when
  // not moving).
  bool moving = false;
  Mode moving_mode = Mode::kNone;
  profile::Motion motion;
  double pos = 0, vel = 0;
  double dir = 1;  // direction of the current (or last) motion, for limits
  double enc_offset = 0;

  void halt() {
    moving = false;
    vel = 0;
  }
  void refresh(std::int64_t now_ns);  // servo-on delay, motion sample at now_ns
  double deceleration() const { return moving_mode == Mode::kJog ? jog.dec : trap.dec; }
};

struct FailRule {
  int function = -1;  // index into kFunctions; -1 = any
  short code = 0;
  int remaining = 0;  // < 0 = forever, 0 = unused slot
};

// Hanging calls: their own lock, never held while a call hangs or while `Sim::mutex` is taken.
struct Hangs {
  std::mutex mutex;
  std::condition_variable released;
  std::atomic<bool> armed{false};  // a rule is set (the fast path of every call reads only this)
  int function = -1;               // the rule: index into kFunctions, -1 = any call
  int block_ms = -1;               // < 0: until released
  std::uint64_t release_generation = 0;
  int hanging = 0;            // calls hanging now (the rule's and the file's)
  std::string file;           // AJAR_SIM_BLOCK_FILE at the first call; empty = none
  bool file_hanging = false;  // a call hangs on the file now (one at a time)

  Hangs();
  // Called by every GT_* call first: hangs when the rule (one call) or the file says so.
  void hang_if_blocked(int function_index);
  void release();  // ends every hanging call, clears the rule
};

Hangs& hangs();

struct Sim {
  std::mutex mutex;
  bool open = false;
  double scale = 1.0;
  bool manual_clock = false;
  Clock::time_point real_base = Clock::now();
  std::int64_t sim_base_ns = 0;
  std::int64_t now_ns = 0;
  double lag_ms = 1.0;
  Axis axes[kAxes];
  FailRule rules[16];
  int calls[kFunctions.size()] = {};
  int total_calls = 0;
  long last_update_mask = 0, last_stop_mask = 0, last_stop_option = 0;
  std::atomic<int> delay_us{0};

  std::int64_t clock_ns() const;
  void rebase();  // the clock continues from now_ns (after a change of scale or of clock)
  // Brings every axis to the current simulated time: O(axes), whatever the time since the last
  // call.
  void advance();
  double encoder(const Axis& a) const;
  long status(const Axis& a) const;  // the GT_GetSts bits
  void reset_axes();
};

Sim& sim();  // the one card of the library

inline bool valid_axis(int axis) {
  return axis >= 1 && axis <= kAxes;
}
inline Axis& axis_at(Sim& s, int axis) {
  return s.axes[axis - 1];
}

// Runs one GT_* call: the configured delay, then under the lock: count, failure rules, open check,
// advance the clock, body. Nothing escapes: an exception inside is execution error (1).
template <typename Body>
short call(const char* name, bool needs_open, Body&& body) noexcept {
  try {
    Sim& s = sim();
    const int index = function_index(name);
    hangs().hang_if_blocked(index);
    const int delay = s.delay_us.load(std::memory_order_relaxed);
    if (delay > 0) std::this_thread::sleep_for(std::chrono::microseconds(delay));
    std::lock_guard lock(s.mutex);
    if (index >= 0) ++s.calls[index];
    ++s.total_calls;
    for (FailRule& rule : s.rules) {
      if (rule.remaining == 0 || (rule.function != -1 && rule.function != index)) continue;
      if (rule.remaining > 0) --rule.remaining;
      return rule.code;
    }
    if (needs_open && !s.open) return -1;
    s.advance();
    return body(s);
  } catch (...) {
    return gts::kCmdExecuteError;
  }
}

// Runs one AjarSim_* control under the lock; an exception inside is swallowed (returns `failed`).
template <typename R, typename Body>
R control(R failed, Body&& body) noexcept {
  try {
    Sim& s = sim();
    std::lock_guard lock(s.mutex);
    return body(s);
  } catch (...) {
    return failed;
  }
}

}  // namespace ajar::drivers::cardsim
