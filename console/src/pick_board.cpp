// The operator's picks, step by step (ajar/console/pick_board.hpp).
#include "ajar/console/pick_board.hpp"

#include <algorithm>
#include <cmath>

#include "ajar/client/client.hpp"
#include "ajar/core/words.hpp"

namespace ajar::console {

using client::JsonObject;

namespace {
// The protocol's name of the field a step's i-th point is sent as.
std::string point_field(Step step, std::size_t i) {
  switch (step) {
    case kWidth:
    case kHandle:
      return i == 0 ? "p1" : "p2";
    case kPlane:
      return "points[" + std::to_string(i) + "]";
    default:
      return "contact";
  }
}

// The pages' word for where a pick stands.
constexpr Word<PickPlace> kPlaceWords[] = {
    {PickPlace::kHere, "here"}, {PickPlace::kMoved, "moved"}, {PickPlace::kStale, "stale"}};

std::string_view place_name(PickPlace p) {
  return word_of(kPlaceWords, p, "stale");
}

const char* missing_picks(Step step) {
  switch (step) {
    case kWidth:
      return "width: pick P1 (hinge side) and P2 (moving edge)";
    case kHandle:
      return "handle: pick the axis, then the free end";
    case kPlane:
      return "plane: pick at least three points on the door, or drag a rectangle";
    default:
      return "contact: pick the contact point on the handle";
  }
}

protocol::Message measurement(Step step, const std::vector<core::Vec3>& points) {
  const auto framed = [](const core::Vec3& p) {
    return client::framed(core::Frame::kCamera, p.x(), p.y(), p.z());
  };
  switch (step) {
    case kWidth:
      return protocol::MeasureDoorWidth{framed(points[0]), framed(points[1])};
    case kHandle:
      return protocol::MeasureHandle{framed(points[0]), framed(points[1])};
    case kPlane: {
      protocol::MeasureDoorPlane plane;
      plane.count = static_cast<std::uint8_t>(points.size());
      for (std::size_t i = 0; i < points.size(); ++i)
        plane.points[i] = framed(points[i]);
      return plane;
    }
    default:
      return protocol::SetContactPoint{framed(points[0])};
  }
}
}  // namespace

bool PickBoard::select(std::string_view name) {
  const auto step = std::find(kStepNames.begin(), kStepNames.end(), name);
  if (step == kStepNames.end()) return false;
  active_ = static_cast<Step>(step - kStepNames.begin());
  return true;
}

std::string PickBoard::add(const Pick& pick) {
  auto& list = picks_[active_];
  if (list.size() >= kStepCapacity[active_]) {
    if (active_ == kPlane) return "the plane takes at most 16 points: send or clear them";
    list.clear();  // width, handle, contact: a new pick starts over
  }
  list.push_back(pick);
  results_[active_] = {};
  return {};
}

void PickBoard::replace_plane(std::vector<Pick> picks) {
  active_ = kPlane;
  picks_[kPlane] = std::move(picks);
  results_[kPlane] = {};
}

void PickBoard::clear_step() {
  picks_[active_].clear();
  results_[active_] = {};
}

void PickBoard::undo() {
  if (!picks_[active_].empty()) picks_[active_].pop_back();
}

void PickBoard::clear_all() {
  for (auto& l : picks_)
    l.clear();
  for (auto& r : results_)
    r = {};
  for (auto& w : sent_)
    w.reset();
  active_ = kWidth;
}

PickBoard::Refused PickBoard::refuse(Step step, const std::string& field,
                                     const std::string& message, const char* code) {
  results_[step] = JsonObject()
                       .add("ok", false)
                       .add("code", code)
                       .add("field", field)
                       .add("message", message)
                       .add("sent", false);
  return Refused{step, field, message};
}

std::variant<PickBoard::Notice, PickBoard::Refused, PickBoard::Ready> PickBoard::send(
    const BoardView& view) {
  const Step step = active_;
  const auto& list = picks_[step];
  const std::size_t need_min = step == kPlane     ? protocol::kMinPlanePoints
                               : step == kContact ? 1
                                                  : 2;
  if (list.size() < need_min || (step != kPlane && list.size() != need_min)) {
    return Notice{missing_picks(step)};
  }
  if (!view.now) return refuse(step, "", view.why_no_pose, "NO_POSE");
  if (view.camera_to_base == nullptr) {
    return refuse(step, "", "the daemon's calibration is not known yet", "NO_POSE");
  }
  const core::PlanarPose& now = *view.now;
  const core::CameraToBase& camera_to_base = *view.camera_to_base;
  // The daemon's rule, pick by pick: the worst motion since any of them.
  PickMotion worst;
  std::size_t worst_i = 0;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const auto mo = pick_motion(list[i].pose, now, view.rule);
    if (static_cast<int>(mo.place) > static_cast<int>(worst.place) ||
        (mo.place == worst.place &&
         mo.travel_m + std::abs(mo.turn_rad) > worst.travel_m + std::abs(worst.turn_rad))) {
      worst = mo;
      worst_i = i;
    }
  }
  if (worst.place == PickPlace::kStale) {
    return refuse(step, point_field(step, worst_i), "pick again: " + moved_text(worst),
                  "PICK_AGAIN");
  }
  std::vector<core::Vec3> points;
  for (const auto& p : list)
    points.push_back(camera_point_now(p.camera_m, p.pose, now, camera_to_base));
  // The handle sits next to the moving edge: cross-check it against the width's P1 (hinge side).
  if (step == kHandle || step == kWidth) {
    const Step other = step == kHandle ? kWidth : kHandle;
    if (sent_[other]) {
      std::vector<core::Vec3> base;  // the other step's points, in the base frame now
      for (const auto& c : sent_[other]->camera_m)
        base.push_back(core::rebase(camera_to_base.to_base(c), sent_[other]->pose, now));
      const core::Vec3 axis = step == kHandle ? camera_to_base.to_base(points[0]) : base[0];
      const core::Vec3 p1 = step == kWidth ? camera_to_base.to_base(points[0]) : base[0];
      const core::Vec3 p2 = step == kWidth ? camera_to_base.to_base(points[1]) : base[1];
      if (const auto problem = hinge_side_problem(p1, p2, axis); !problem.empty()) {
        return refuse(step, step == kHandle ? "width.p1" : "p1", problem, "HINGE_SIDE");
      }
    }
  }
  std::string note;
  if (worst.place == PickPlace::kMoved) {
    note = "transformed by odometry: " + moved_text(worst) + " the picks (within the daemon's " +
           "staleness rule): sent as seen from here";
  }
  return Ready{step, measurement(step, points), note, SentStep{points, now}};
}

void PickBoard::answered(Step step, JsonObject reply, bool accepted, const SentStep& what) {
  results_[step] = std::move(reply);
  if (accepted) sent_[step] = what;
}

// Each pick with the pose it was taken at and how far the base moved since (to the newest
// telemetry): "here", "moved" (within the daemon's staleness rule: sent transformed) or "stale".
JsonObject PickBoard::picks_json(const BoardView& view) const {
  JsonObject o;
  for (std::size_t s = 0; s < kStepCount; ++s) {
    client::JsonArray items;
    for (const auto& p : picks_[s]) {
      JsonObject j;
      j.add("u", p.u_px)
          .add("v", p.v_px)
          .add("camera_m", p.camera_m)
          .add("from_window", p.from_window)
          .add("frame", static_cast<std::uint64_t>(p.frame_sequence))
          .add("pose", client::JsonArray().add(p.pose.x_m).add(p.pose.y_m).add(p.pose.yaw_rad));
      if (view.camera_to_base != nullptr) j.add("base_m", view.camera_to_base->to_base(p.camera_m));
      if (view.now) {
        const auto m = pick_motion(p.pose, *view.now, view.rule);
        j.add("place", place_name(m.place));
        if (m.place != PickPlace::kHere) j.add("moved", moved_text(m));
      }
      items.add(j);
    }
    o.add(kStepNames[s], items);
  }
  return o;
}

// Each pick seen from the frame's pose (its pixel), and its place by the daemon's staleness rule;
// "out" when it is not in this image.
JsonObject PickBoard::markers_json(const core::PlanarPose& at_frame,
                                   const core::PinholeIntrinsics& k, const BoardView& view) const {
  JsonObject markers;
  for (std::size_t s = 0; s < kStepCount; ++s) {
    client::JsonArray items;
    for (const auto& p : picks_[s]) {
      const auto m = pick_motion(p.pose, at_frame, view.rule);
      JsonObject j;
      if (m.place == PickPlace::kHere || view.camera_to_base == nullptr) {
        j.add("u", p.u_px)
            .add("v", p.v_px)
            .add("place", m.place == PickPlace::kHere ? "here" : "stale");
      } else {
        const auto px =
            core::project(k, camera_point_now(p.camera_m, p.pose, at_frame, *view.camera_to_base));
        const bool in = px && px->u_px >= -0.5 && px->v_px >= -0.5 &&
                        px->u_px <= k.width_px - 0.5 && px->v_px <= k.height_px - 0.5;
        if (px) j.add("u", px->u_px).add("v", px->v_px);
        j.add("place", in ? place_name(m.place) : "out");
      }
      items.add(j);
    }
    markers.add(kStepNames[s], items);
  }
  return markers;
}

JsonObject PickBoard::results_json() const {
  JsonObject o;
  for (std::size_t s = 0; s < kStepCount; ++s) {
    if (!results_[s].empty()) o.add(kStepNames[s], results_[s]);
  }
  return o;
}

}  // namespace ajar::console
