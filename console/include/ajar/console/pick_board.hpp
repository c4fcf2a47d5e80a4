// PickBoard: the operator's picks in the parameter region (paper, section III.A), step by step, and
// what became of each step's measurement. No sockets, no threads, no clock: the console's Asio
// thread owns its one board and gives it what it needs (the base pose now, the calibration, the
// daemon's staleness rule); the console tests drive it directly.
//
// Rules (docs/console.md): a width, handle or contact pick on a full step starts the step over; the
// plane holds at most protocol::kMaxPlanePoints picks (a pick beyond is refused); a new pick
// forgets the step's last reply. A step is sent in the camera frame of the base's pose NOW: picks
// the base moved away from are seen from here through odometry while within the daemon's staleness
// rule, and refused beyond it (the point to pick again is named); the width and the handle are
// cross-checked against each other's accepted points (the handle sits next to the moving edge).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "ajar/client/json.hpp"
#include "ajar/console/pick_pose.hpp"
#include "ajar/core/camera.hpp"
#include "ajar/core/geometry.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::console {

// The parameter region's steps, in the procedure's order, and how many picks each holds.
enum Step : std::size_t { kWidth = 0, kHandle = 1, kPlane = 2, kContact = 3, kStepCount = 4 };
inline constexpr std::array<const char*, kStepCount> kStepNames{"width", "handle", "plane",
                                                                "contact"};
inline constexpr std::array<std::size_t, kStepCount> kStepCapacity{2, 2, protocol::kMaxPlanePoints,
                                                                   1};

// One point the operator picked on a frame (camera frame, metres), with the base pose of that
// frame: the daemon's odometry when the frame was captured (ajar/console/pick_pose.hpp).
struct Pick {
  double u_px = 0;
  double v_px = 0;
  core::Vec3 camera_m = core::Vec3::Zero();
  bool from_window = false;  // depth from the pick rule's window median (a hole at the pixel)
  std::uint64_t frame_sequence = 0;
  core::PlanarPose pose;  // odometry of the frame it was picked on
};

// What a step's accepted measurement was taken from: the points as sent (camera frame at `pose`).
struct SentStep {
  std::vector<core::Vec3> camera_m;
  core::PlanarPose pose;
};

// What the board knows of the robot when it sends or draws picks.
struct BoardView {
  std::optional<core::PlanarPose> now;                 // the base pose now; nullopt: unknown ...
  std::string why_no_pose;                             // ... and why
  const core::CameraToBase* camera_to_base = nullptr;  // the daemon's calibration (null: unknown)
  StaleRule rule;                                      // the daemon's staleness rule
};

class PickBoard {
 public:
  Step active() const noexcept { return active_; }
  // Makes the step named `name` ("width", ...) active. False: no such step.
  bool select(std::string_view name);

  const std::vector<Pick>& picks(Step step) const { return picks_[step]; }
  const std::optional<SentStep>& sent(Step step) const { return sent_[step]; }  // accepted
  const client::JsonObject& result(Step step) const { return results_[step]; }  // empty: none

  // A pick on the active step. Empty, or why it was not taken (a full plane).
  std::string add(const Pick& pick);
  // A rectangle's points: the plane becomes the active step and holds exactly these.
  void replace_plane(std::vector<Pick> picks);
  void clear_step();  // the active step's picks and reply
  void undo();        // the active step's last pick
  void clear_all();   // Reset with clear_parameters: every pick, reply and accepted step

  // Sending the active step.
  struct Notice {  // not enough picks for the step: nothing recorded
    std::string text;
  };
  struct Refused {  // not sent: recorded as the step's reply
    Step step;
    std::string field;
    std::string message;
  };
  struct Ready {  // the measurement to send, and what it was taken from
    Step step;
    protocol::Message message;
    std::string note;  // non-empty when the picks were transformed by odometry
    SentStep what;
  };
  std::variant<Notice, Refused, Ready> send(const BoardView& view);
  // ajard's reply to a Ready: the step's reply; an accepted step remembers what it was.
  void answered(Step step, client::JsonObject reply, bool accepted, const SentStep& what);

  // {"width": [{u, v, camera_m, from_window, frame, pose, base_m?, place?, moved?}...], ...}
  client::JsonObject picks_json(const BoardView& view) const;
  // Each pick seen from a frame taken at `at_frame`: its pixel and place ("out": not in view).
  client::JsonObject markers_json(const core::PlanarPose& at_frame,
                                  const core::PinholeIntrinsics& k, const BoardView& view) const;
  client::JsonObject results_json() const;  // the steps' replies, by step name

 private:
  Refused refuse(Step step, const std::string& field, const std::string& message, const char* code);

  std::array<std::vector<Pick>, kStepCount> picks_;
  std::array<client::JsonObject, kStepCount> results_;    // the replies; empty: nothing sent yet
  std::array<std::optional<SentStep>, kStepCount> sent_;  // what each accepted measurement was
  Step active_ = kWidth;
};

}  // namespace ajar::console
