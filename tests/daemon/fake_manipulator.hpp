// FakeManipulator: a scripted arm for engine tests. The test sets the phase the arm reports and
// observes hand-offs and stops through a shared FakeArmControl. Thread-safe.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "ajar/drivers/manipulator.hpp"

namespace ajar::testing {

struct FakeArmControl {
  mutable std::mutex mutex;
  drivers::ArmStatus status{drivers::ArmPhase::kIdle, ErrorCode::kOk, 0, 0};
  bool refuse_hand_off = false;
  std::vector<drivers::DoorTask> tasks;
  int stops = 0;
  int clear_faults = 0;

  template <typename F>
  auto with_lock(F f) {
    std::lock_guard lock(mutex);
    return f(*this);
  }
  void set_phase(drivers::ArmPhase phase, ErrorCode error = ErrorCode::kOk) {
    std::lock_guard lock(mutex);
    status.phase = phase;
    status.last_error = error;
  }
};

class FakeManipulator final : public drivers::Manipulator {
 public:
  explicit FakeManipulator(std::shared_ptr<FakeArmControl> control) : c_(std::move(control)) {}

  Outcome connect() override { return Ok{}; }
  Outcome disconnect() override { return Ok{}; }
  Result<std::uint32_t> hand_off(const drivers::DoorTask& task) override {
    std::lock_guard lock(c_->mutex);
    if (c_->refuse_hand_off) {
      return make_error(ErrorCode::kArmDisconnected, "", "fake: arm disconnected");
    }
    c_->tasks.push_back(task);
    c_->status.phase = drivers::ArmPhase::kBusy;
    c_->status.task_id = static_cast<std::uint32_t>(c_->tasks.size());
    return c_->status.task_id;
  }
  Outcome stop() override {
    std::lock_guard lock(c_->mutex);
    ++c_->stops;
    if (c_->status.phase == drivers::ArmPhase::kBusy) c_->status.phase = drivers::ArmPhase::kIdle;
    return Ok{};
  }
  Outcome clear_fault() override {
    std::lock_guard lock(c_->mutex);
    ++c_->clear_faults;
    if (c_->status.phase == drivers::ArmPhase::kFault) c_->status.phase = drivers::ArmPhase::kIdle;
    return Ok{};
  }
  drivers::ArmStatus status() const override {
    std::lock_guard lock(c_->mutex);
    return c_->status;
  }

 private:
  std::shared_ptr<FakeArmControl> c_;
};

}  // namespace ajar::testing
