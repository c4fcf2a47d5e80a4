// What a page asks over its WebSocket (docs/console.md lists the ops): hover and pick on a frame,
// a rectangle of plane points, the active step, sending a step's measurement, the procedure's
// commands (Stop and EmergencyStop on their own worker), jog (coalesced), Approach, take-over and
// observer. Bad messages get a notice naming what was wrong; nothing reaches the robot then.
#include "server_impl.hpp"

#include <algorithm>
#include <array>
#include <cstdio>

#include "ajar/client/json.hpp"
#include "daemon_json.hpp"

namespace ajar::console {

using client::JsonObject;

void ConsoleServer::Impl::handle_page(const std::shared_ptr<WsSession>& s,
                                      const std::string& text) {
  std::string error;
  const auto m = PageMessage::parse(text, error);
  if (!m) {
    notice(s, error);
    return;
  }
  const std::string op = m->op();
  if (op == "alive") {
    s->last_alive = Clock::now();
    update_heartbeat();
  } else if (op == "overlay") {
    s->overlay = m->flag("on").value_or(false);
    update_overlay();
  } else if (op == "hover") {
    hover(s, *m);
  } else if (op == "step") {
    const auto name = m->text("step").value_or("");
    const auto step = std::find(kStepNames.begin(), kStepNames.end(), name);
    if (step == kStepNames.end()) return notice(s, "unknown step");
    active = static_cast<Step>(step - kStepNames.begin());
    mark_dirty();
  } else if (op == "pick") {
    pick(s, *m);
  } else if (op == "rect") {
    rect(s, *m);
  } else if (op == "clear") {
    picks[active].clear();
    results[active] = {};
    mark_dirty();
  } else if (op == "undo") {
    if (!picks[active].empty()) picks[active].pop_back();
    mark_dirty();
  } else if (op == "send") {
    send_step(s);
  } else if (op == "align" || op == "engage" || op == "reset" || op == "stop" || op == "estop") {
    command(op, m->flag("clear").value_or(false));
  } else if (op == "save_recording") {
    save_recording(m->number("last_s").value_or(kSaveLast_s));
  } else if (op == "drive") {
    drive(s, *m);
  } else if (op == "approach") {
    approach(s, *m);
  } else if (op == "take_over") {
    add_log("taking over control");
    worker->post([this] {
      client.close();
      role = protocol::Role::kController;
      take_over_next = true;
      connect_now();
    });
  } else if (op == "observe") {
    add_log("switching to observer");
    worker->post([this] {
      client.close();
      role = protocol::Role::kObserver;
      connect_now();
    });
  } else {
    notice(s, "PAGE_MESSAGE: unknown op '" + op + "'");
  }
}

std::shared_ptr<const FrameEntry> ConsoleServer::Impl::frame_for(const PageMessage& m) const {
  if (frames.empty()) return nullptr;
  if (const auto seq = m.number("seq")) {
    for (const auto& f : frames) {
      if (static_cast<double>(static_cast<std::uint32_t>(f->frame.sequence)) == *seq) return f;
    }
  }
  return frames.back();
}

void ConsoleServer::Impl::hover(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto u = m.number("u");
  const auto v = m.number("v");
  const auto f = frame_for(m);
  JsonObject o;
  o.add("type", "hover");
  if (!u || !v || !f) {
    o.add("ok", false).add("message", f ? "u and v needed" : "no frame yet");
    return reply(s, o.str());
  }
  o.add("u", *u).add("v", *v);
  const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), *u, *v);
  if (!p) {
    o.add("ok", false).add("field", p.error().field).add("message", p.error().message);
    return reply(s, o.str());
  }
  o.add("ok", true)
      .add("camera_m", p->camera_m)
      .add("depth_m", p->depth_m)
      .add("from_window", p->from_window);
  if (camera_to_base) o.add("base_m", camera_to_base->to_base(p->camera_m));
  reply(s, o.str());
}

namespace {
std::string seconds_text(Clock::duration d) {
  std::array<char, 32> buf{};
  std::snprintf(buf.data(), buf.size(), "%.1f s", std::chrono::duration<double>(d).count());
  return buf.data();
}
core::PlanarPose planar(const BasePose& p) {
  return {p.x_m, p.y_m, p.yaw_rad};
}
}  // namespace

// Why a pick on frame `f` cannot be trusted (empty when it can): a frozen camera, or no pose.
std::string ConsoleServer::Impl::frame_problem(const FrameEntry& f, bool pose_too) const {
  const auto now = Clock::now();
  if (frames.empty() || now - frames.back()->captured > kFrozenAfter) {
    return "the image is FROZEN: no frame from the camera for " +
           seconds_text(now - (frames.empty() ? f.captured : frames.back()->captured)) +
           ": nothing picked";
  }
  if (!pose_too) return "";
  if (f.pose_from == Clock::time_point{} || f.captured - f.pose_from > kFrozenAfter) {
    return "no telemetry from ajard when this frame was taken: where the base was is unknown: "
           "nothing picked";
  }
  return "";
}

void ConsoleServer::Impl::refuse_pick(const std::shared_ptr<WsSession>& s, const std::string& field,
                                      const std::string& message) {
  add_log("pick refused: " + message);
  reply(s,
        JsonObject().add("type", "pick_refused").add("field", field).add("message", message).str());
}

void ConsoleServer::Impl::pick(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto u = m.number("u");
  const auto v = m.number("v");
  const auto f = frame_for(m);
  if (!u || !v || !f) return notice(s, f ? "pick: u and v needed" : "pick: no frame yet");
  if (const auto why = frame_problem(*f, false); !why.empty()) return refuse_pick(s, "frame", why);
  const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), *u, *v);
  if (!p) return refuse_pick(s, p.error().field, p.error().message);
  if (const auto why = frame_problem(*f, true); !why.empty()) return refuse_pick(s, "frame", why);
  auto& list = picks[active];
  if (list.size() >= kStepCapacity[active]) {
    if (active == kPlane) {
      return notice(s, "the plane takes at most 16 points: send or clear them");
    }
    list.clear();  // width, handle, contact: a new pick starts over
  }
  list.push_back({*u, *v, p->camera_m, p->from_window, f->frame.sequence, planar(f->pose)});
  results[active] = {};
  mark_dirty();
}

// Up to 16 well-spread valid points inside a rectangle: a 4x4 grid of cells, in each the valid
// pixel nearest the cell's centre (the pick rule's window median for holes).
void ConsoleServer::Impl::rect(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto u0 = m.number("u0");
  const auto v0 = m.number("v0");
  const auto u1 = m.number("u1");
  const auto v1 = m.number("v1");
  const auto f = frame_for(m);
  if (!u0 || !v0 || !u1 || !v1 || !f) return notice(s, "rect: u0, v0, u1, v1 needed");
  if (const auto why = frame_problem(*f, true); !why.empty()) return refuse_pick(s, "frame", why);
  const double ul = std::min(*u0, *u1);
  const double ur = std::max(*u0, *u1);
  const double vt = std::min(*v0, *v1);
  const double vb = std::max(*v0, *v1);
  std::vector<Pick> found;
  constexpr int kGrid = 4;
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      const double u = ul + (ur - ul) * (i + 0.5) / kGrid;
      const double v = vt + (vb - vt) * (j + 0.5) / kGrid;
      const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), u, v);
      if (p) {
        found.push_back({u, v, p->camera_m, p->from_window, f->frame.sequence, planar(f->pose)});
      }
    }
  }
  if (found.size() < protocol::kMinPlanePoints) {
    add_log("rectangle refused: only " + std::to_string(found.size()) +
            " of 16 points have depth; drag over a measurable part of the door");
    return;
  }
  active = kPlane;
  picks[kPlane] = std::move(found);
  results[kPlane] = {};
  mark_dirty();
}

std::optional<core::PlanarPose> ConsoleServer::Impl::pose_now(std::string& why) const {
  const auto age = Clock::now() - telemetry_at;
  if (!telemetry || age > kFrozenAfter) {
    why = telemetry ? "no telemetry from ajard for " + seconds_text(age) +
                          ": whether the base moved since the picks is unknown"
                    : "no telemetry from ajard yet: where the base is is unknown";
    return std::nullopt;
  }
  return core::PlanarPose{telemetry->odometry_x_m, telemetry->odometry_y_m,
                          telemetry->base_yaw_odometry_rad};
}

StaleRule ConsoleServer::Impl::stale_rule() const {
  return model ? StaleRule{model->stale_travel_m, model->stale_yaw_rad} : StaleRule{};
}

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
}  // namespace

// A step's picks go to ajard in the camera frame of the base's pose NOW: picks taken before the
// base moved are seen from here through odometry when the motion is within the daemon's staleness
// rule (the page says so), and refused beyond it ("pick again: the base moved 0.070 m / 1.3°
// since").
void ConsoleServer::Impl::send_step(const std::shared_ptr<WsSession>& s) {
  const Step step = active;
  const auto& list = picks[step];
  const auto refuse = [&](const std::string& field, const std::string& message,
                          const char* code = "PICK_AGAIN") {
    results[step] = JsonObject()
                        .add("ok", false)
                        .add("code", code)
                        .add("field", field)
                        .add("message", message)
                        .add("sent", false);
    add_log(std::string(kStepNames[step]) + ": not sent: " + message);
    mark_dirty();
  };
  const std::size_t need_min = step == kPlane     ? protocol::kMinPlanePoints
                               : step == kContact ? 1
                                                  : 2;
  if (list.size() < need_min || (step != kPlane && list.size() != need_min)) {
    switch (step) {
      case kWidth:
        return notice(s, "width: pick P1 (hinge side) and P2 (moving edge)");
      case kHandle:
        return notice(s, "handle: pick the axis, then the free end");
      case kPlane:
        return notice(s, "plane: pick at least three points on the door, or drag a rectangle");
      default:
        return notice(s, "contact: pick the contact point on the handle");
    }
  }
  std::string why;
  const auto now = pose_now(why);
  if (!now) return refuse("", why, "NO_POSE");
  if (!camera_to_base) return refuse("", "the daemon's calibration is not known yet", "NO_POSE");
  // The daemon's rule, pick by pick: the worst motion since any of them.
  PickMotion worst;
  std::size_t worst_i = 0;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const auto mo = pick_motion(list[i].pose, *now, stale_rule());
    if (static_cast<int>(mo.place) > static_cast<int>(worst.place) ||
        (mo.place == worst.place &&
         mo.travel_m + std::abs(mo.turn_rad) > worst.travel_m + std::abs(worst.turn_rad))) {
      worst = mo;
      worst_i = i;
    }
  }
  if (worst.place == PickPlace::kStale) {
    return refuse(point_field(step, worst_i), "pick again: " + moved_text(worst));
  }
  std::vector<core::Vec3> points;
  for (const auto& p : list)
    points.push_back(camera_point_now(p.camera_m, p.pose, *now, *camera_to_base));
  // The handle sits next to the moving edge: cross-check it against the width's P1 (hinge side).
  if (step == kHandle || step == kWidth) {
    const Step other = step == kHandle ? kWidth : kHandle;
    if (sent[other]) {
      std::vector<core::Vec3> base;  // this step's points and the other's, in the base frame now
      for (const auto& c : sent[other]->camera_m)
        base.push_back(core::rebase(camera_to_base->to_base(c), sent[other]->pose, *now));
      const core::Vec3 axis = step == kHandle ? camera_to_base->to_base(points[0]) : base[0];
      const core::Vec3 p1 = step == kWidth ? camera_to_base->to_base(points[0]) : base[0];
      const core::Vec3 p2 = step == kWidth ? camera_to_base->to_base(points[1]) : base[1];
      if (const auto problem = hinge_side_problem(p1, p2, axis); !problem.empty()) {
        return refuse(step == kHandle ? "width.p1" : "p1", problem, "HINGE_SIDE");
      }
    }
  }
  std::string note;
  if (worst.place == PickPlace::kMoved) {
    note = "transformed by odometry: " + moved_text(worst) + " the picks (within the daemon's " +
           "staleness rule): sent as seen from here";
  }
  const auto framed = [](const core::Vec3& p) {
    return client::framed(core::Frame::kCamera, p.x(), p.y(), p.z());
  };
  protocol::Message msg;
  switch (step) {
    case kWidth:
      msg = protocol::MeasureDoorWidth{framed(points[0]), framed(points[1])};
      break;
    case kHandle:
      msg = protocol::MeasureHandle{framed(points[0]), framed(points[1])};
      break;
    case kPlane: {
      protocol::MeasureDoorPlane plane;
      plane.count = static_cast<std::uint8_t>(points.size());
      for (std::size_t i = 0; i < points.size(); ++i)
        plane.points[i] = framed(points[i]);
      msg = plane;
      break;
    }
    case kContact:
      msg = protocol::SetContactPoint{framed(points[0])};
      break;
    case kStepCount:
      return;
  }
  add_log(std::string("sending ") + std::string(protocol::to_string(protocol::type_of(msg))) +
          (note.empty() ? "" : " (" + note + ")"));
  const SentStep what{points, *now};
  worker->post([this, step, msg, note, what] {
    const auto r = client.request(msg);
    auto json = response_json(r);
    if (!note.empty()) json.add("note", note);
    on_io([this, step, json, r, what] {
      results[step] = json;
      if (r.ok()) sent[step] = what;
      on_reply(r);
      log_response(std::string(kStepNames[step]), r);
      mark_dirty();
    });
    refresh_status();
  });
}

void ConsoleServer::Impl::command(const std::string& op, bool clear) {
  protocol::Message msg;
  if (op == "align") msg = protocol::AlignBase{};
  if (op == "engage") msg = protocol::Engage{};
  if (op == "reset") msg = protocol::Reset{clear};
  if (op == "stop") msg = protocol::Stop{};
  if (op == "estop") msg = protocol::EmergencyStop{};
  const bool urgent = op == "stop" || op == "estop";
  add_log(std::string(urgent ? "!! " : "") + "sending " +
          std::string(protocol::to_string(protocol::type_of(msg))) +
          (clear ? " (clear parameters)" : ""));
  if (clear) {
    for (auto& l : picks)
      l.clear();
    for (auto& r : results)
      r = {};
    for (auto& w : sent)
      w.reset();
    active = kWidth;
    mark_dirty();
  }
  auto job = [this, op, msg] {
    const auto r = client.request(msg, std::chrono::milliseconds(1000), 2);
    const auto json = response_json(r);
    on_io([this, op, json, r] {
      last_command = JsonObject().add("op", op).add("reply", json).add("at", now_hms());
      on_reply(r);
      log_response(op, r);
      mark_dirty();
    });
    refresh_status();
  };
  (urgent ? stop_worker : worker)->post(std::move(job));
}

// Jog: coalesced, so a slow daemon never sees a backlog of old velocities.
void ConsoleServer::Impl::drive(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto linear = m.number("linear");
  const auto angular = m.number("angular");
  if (!linear || !angular) return notice(s, "drive: linear and angular needed");
  bool post = false;
  {
    const std::lock_guard lock(drive_mutex);
    pending_drive = protocol::Drive{*linear, *angular};
    post = !drive_queued;
    drive_queued = true;
  }
  if (!post) return;
  worker->post([this] {
    protocol::Drive d;
    {
      const std::lock_guard lock(drive_mutex);
      d = pending_drive;
      drive_queued = false;
    }
    const auto r = client.request(d, std::chrono::milliseconds(300), 0);
    if (!r.ok()) {
      // A held jog re-sends every 100 ms: the refusal is shown (last command) and logged once
      // per code and at most every 2 s, not ten times a second.
      on_io([this, r, json = response_json(r)] {
        on_reply(r);
        last_command = JsonObject().add("op", "drive").add("reply", json).add("at", now_hms());
        const std::string code = json.str();
        if (code != last_drive_refusal ||
            Clock::now() - last_drive_refusal_at > std::chrono::seconds(2)) {
          log_response("drive", r);
          last_drive_refusal = code;
          last_drive_refusal_at = Clock::now();
        }
        mark_dirty();
      });
    }
  });
}

void ConsoleServer::Impl::approach(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto standoff = m.number("standoff_m");
  if (!standoff) return notice(s, "approach: standoff_m needed");
  add_log("sending Approach to " + client::json_number(*standoff) + " m");
  const protocol::Message msg = protocol::Approach{*standoff};
  worker->post([this, msg] {
    const auto r = client.request(msg);
    const auto json = response_json(r);
    on_io([this, json, r] {
      last_command = JsonObject().add("op", "approach").add("reply", json).add("at", now_hms());
      on_reply(r);
      log_response("approach", r);
      mark_dirty();
    });
    refresh_status();
  });
}

void ConsoleServer::Impl::log_response(const std::string& what, const client::Response& r) {
  if (r.outcome == client::CallOutcome::kReply) {
    add_log(what + ": accepted");
  } else if (r.outcome == client::CallOutcome::kRefused) {
    add_log(what + ": refused " + std::string(ajar::to_string(r.error.code)) +
            (r.error.field.view().empty() ? "" : " (" + std::string(r.error.field.view()) + ")") +
            ": " + std::string(r.error.message.view()));
  } else {
    add_log(what + ": " + std::string(client::to_string(r.outcome)) + ": " + r.transport_error);
  }
}

}  // namespace ajar::console
