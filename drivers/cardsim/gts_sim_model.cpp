#include "gts_sim_model.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace ajar::drivers::cardsim {

int function_index(const char* name) {
  for (std::size_t i = 0; i < kFunctions.size(); ++i) {
    if (std::strcmp(kFunctions[i], name) == 0) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

void Axis::refresh(std::int64_t now_ns) {
  if (servo_on_at_ns >= 0 && now_ns >= servo_on_at_ns) {
    servo_on_at_ns = -1;
    if (!alarm) servo = true;
  }
  if (!moving) return;
  const profile::Sample s = profile::sample(motion, now_ns);
  pos = s.position;
  vel = s.velocity;
  if (s.done) halt();
}

std::int64_t Sim::clock_ns() const {
  if (manual_clock) return now_ns;
  const auto real_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - real_base).count();
  return sim_base_ns + std::llround(static_cast<double>(real_ns) * scale);
}

void Sim::rebase() {
  sim_base_ns = now_ns;
  real_base = Clock::now();
}

void Sim::advance() {
  now_ns = std::max(now_ns, clock_ns());
  for (Axis& a : axes)
    a.refresh(now_ns);
}

double Sim::encoder(const Axis& a) const {
  const double lag = a.moving ? a.vel * lag_ms : 0.0;
  return a.pos - lag + a.enc_offset;
}

long Sim::status(const Axis& a) const {
  long s = 0;
  if (a.alarm) s |= gts::kStsDriveAlarm;
  if (a.following_error) s |= gts::kStsFollowingError;
  if (a.positive_limit) s |= gts::kStsPositiveLimit;
  if (a.negative_limit) s |= gts::kStsNegativeLimit;
  if (a.smooth_stopped) s |= gts::kStsSmoothStop;
  if (a.emergency_stopped) s |= gts::kStsEmergencyStop;
  if (a.servo) s |= gts::kStsServoOn;
  if (a.moving) s |= gts::kStsProfileMoving;
  if (!a.moving && a.servo && std::fabs(encoder(a) - a.pos) < 1.0) s |= gts::kStsInPosition;
  return s;
}

void Sim::reset_axes() {
  for (Axis& a : axes)
    a = Axis{};
}

Sim& sim() {
  static Sim s;
  return s;
}

Hangs::Hangs() {
  if (const char* path = std::getenv("AJAR_SIM_BLOCK_FILE"); path != nullptr) file = path;
}

void Hangs::hang_if_blocked(int function_index) {
  if (armed.load(std::memory_order_acquire)) {
    std::unique_lock lock(mutex);
    if (armed.load(std::memory_order_relaxed) && (function == -1 || function == function_index)) {
      armed.store(false, std::memory_order_relaxed);  // one call
      const std::uint64_t generation = release_generation;
      const auto done = [&] { return release_generation != generation; };
      ++hanging;
      if (block_ms < 0) {
        released.wait(lock, done);
      } else {
        released.wait_for(lock, std::chrono::milliseconds(block_ms), done);
      }
      --hanging;
    }
  }
  if (file.empty()) return;
  std::uint64_t generation = 0;
  {
    const std::lock_guard lock(mutex);
    if (file_hanging || ::access(file.c_str(), F_OK) != 0) return;
    file_hanging = true;
    ++hanging;
    generation = release_generation;
  }
  for (;;) {  // until the file is removed (or AjarSim_ReleaseBlockedCalls)
    std::unique_lock lock(mutex);
    if (released.wait_for(lock, std::chrono::milliseconds(1),
                          [&] { return release_generation != generation; }) ||
        ::access(file.c_str(), F_OK) != 0) {
      file_hanging = false;
      --hanging;
      return;
    }
  }
}

void Hangs::release() {
  {
    const std::lock_guard lock(mutex);
    armed.store(false, std::memory_order_relaxed);
    ++release_generation;
  }
  released.notify_all();
}

Hangs& hangs() {
  static Hangs h;
  return h;
}

}  // namespace ajar::drivers::cardsim
