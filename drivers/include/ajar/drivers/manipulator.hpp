// Manipulator: the 6-DoF arm as the daemon sees it. The real implementation speaks the line
// protocol of docs/manipulator-serial.md over RS-232 on its own worker thread; every call here
// returns promptly (it queues work or reads a snapshot) so the control loop is never blocked by the
// serial line.
#pragma once

#include <cstdint>

#include "ajar/core/result.hpp"
#include "ajar/core/types.hpp"

namespace ajar::drivers {

// Everything the arm needs to open the door (paper, IV and [9]).
struct DoorTask {
  core::Vec3 contact_base_m = core::Vec3::Zero();
  double door_width_m = 0;
  double handle_length_m = 0;
  core::RotationDirection door_direction = core::RotationDirection::kClockwise;
  core::RotationDirection handle_direction = core::RotationDirection::kClockwise;
};

enum class ArmPhase : std::uint8_t {
  kDisconnected = 0,  // no link to the arm controller (cable pulled, device missing)
  kIdle = 1,          // connected, no task
  kBusy = 2,          // a task was handed off and acknowledged; the arm is working
  kDone = 3,          // the arm reported the task complete
  kFault = 4,         // the arm controller reported a fault or refused a task
};

struct ArmStatus {
  ArmPhase phase = ArmPhase::kDisconnected;
  ErrorCode last_error = ErrorCode::kOk;  // why it is in kFault / kDisconnected
  std::uint32_t task_id = 0;              // last task handed off (0 = none)
  std::uint32_t reconnects = 0;
};

class Manipulator {
 public:
  virtual ~Manipulator() = default;

  // Starts the link (opens the device, starts the worker). Start-up only.
  virtual Outcome connect() = 0;
  virtual Outcome disconnect() = 0;
  // Queues the hand-off of a task; returns the task id at once. The acknowledgement, retries and
  // outcome show up in status(). Refuses (kArmDisconnected, kWrongState) without queueing.
  virtual Result<std::uint32_t> hand_off(const DoorTask& task) = 0;
  // Stops the arm (queued ahead of anything else). Never blocks.
  virtual Outcome stop() = 0;
  virtual Outcome clear_fault() = 0;
  virtual ArmStatus status() const = 0;
};

}  // namespace ajar::drivers
