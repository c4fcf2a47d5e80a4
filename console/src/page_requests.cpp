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
    pages.notice(s, error);
    return;
  }
  const std::string op = m->op();
  if (op == "alive") {
    s->last_alive = Clock::now();
    update_heartbeat();
  } else if (op == "overlay") {
    pages.set_overlay(s, m->flag("on").value_or(false));
  } else if (op == "hover") {
    hover(s, *m);
  } else if (op == "step") {
    if (!board.select(m->text("step").value_or(""))) return pages.notice(s, "unknown step");
    mark_dirty();
  } else if (op == "pick") {
    pick(s, *m);
  } else if (op == "rect") {
    rect(s, *m);
  } else if (op == "clear") {
    board.clear_step();
    mark_dirty();
  } else if (op == "undo") {
    board.undo();
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
    link.take_over();
  } else if (op == "observe") {
    add_log("switching to observer");
    link.observe();
  } else {
    pages.notice(s, "PAGE_MESSAGE: unknown op '" + op + "'");
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
    return pages.reply(s, o.str());
  }
  o.add("u", *u).add("v", *v);
  const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), *u, *v);
  if (!p) {
    o.add("ok", false).add("field", p.error().field).add("message", p.error().message);
    return pages.reply(s, o.str());
  }
  o.add("ok", true)
      .add("camera_m", p->camera_m)
      .add("depth_m", p->depth_m)
      .add("from_window", p->from_window);
  if (camera_to_base) o.add("base_m", camera_to_base->to_base(p->camera_m));
  pages.reply(s, o.str());
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
  pages.reply(
      s,
      JsonObject().add("type", "pick_refused").add("field", field).add("message", message).str());
}

void ConsoleServer::Impl::pick(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto u = m.number("u");
  const auto v = m.number("v");
  const auto f = frame_for(m);
  if (!u || !v || !f) return pages.notice(s, f ? "pick: u and v needed" : "pick: no frame yet");
  if (const auto why = frame_problem(*f, false); !why.empty()) return refuse_pick(s, "frame", why);
  const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), *u, *v);
  if (!p) return refuse_pick(s, p.error().field, p.error().message);
  if (const auto why = frame_problem(*f, true); !why.empty()) return refuse_pick(s, "frame", why);
  const std::string full =
      board.add({*u, *v, p->camera_m, p->from_window, f->frame.sequence, planar(f->pose)});
  if (!full.empty()) return pages.notice(s, full);
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
  if (!u0 || !v0 || !u1 || !v1 || !f) return pages.notice(s, "rect: u0, v0, u1, v1 needed");
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
  board.replace_plane(std::move(found));
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

BoardView ConsoleServer::Impl::board_view() const {
  BoardView v;
  v.now = pose_now(v.why_no_pose);
  v.camera_to_base = camera_to_base ? &*camera_to_base : nullptr;
  v.rule = stale_rule();
  return v;
}

// A step's picks go to ajard in the camera frame of the base's pose NOW (PickBoard::send): picks
// taken before the base moved are seen from here through odometry when the motion is within the
// daemon's staleness rule (the page says so), and refused beyond it ("pick again: the base moved
// 0.070 m / 1.3° since").
void ConsoleServer::Impl::send_step(const std::shared_ptr<WsSession>& s) {
  auto plan = board.send(board_view());
  if (const auto* n = std::get_if<PickBoard::Notice>(&plan)) return pages.notice(s, n->text);
  if (const auto* r = std::get_if<PickBoard::Refused>(&plan)) {
    add_log(std::string(kStepNames[r->step]) + ": not sent: " + r->message);
    mark_dirty();
    return;
  }
  auto ready = std::get<PickBoard::Ready>(std::move(plan));
  add_log(std::string("sending ") +
          std::string(protocol::to_string(protocol::type_of(ready.message))) +
          (ready.note.empty() ? "" : " (" + ready.note + ")"));
  link.post([this, ready = std::move(ready)] {
    const auto r = link.client().request(ready.message);
    auto json = response_json(r);
    if (!ready.note.empty()) json.add("note", ready.note);
    on_io([this, step = ready.step, json, r, what = ready.what] {
      board.answered(step, json, r.ok(), what);
      on_reply(r);
      log_response(std::string(kStepNames[step]), r);
      mark_dirty();
    });
    link.refresh_status();
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
    board.clear_all();
    mark_dirty();
  }
  auto job = [this, op, msg] {
    const auto r = link.client().request(msg, std::chrono::milliseconds(1000), 2);
    const auto json = response_json(r);
    on_io([this, op, json, r] {
      last_command = JsonObject().add("op", op).add("reply", json).add("at", now_hms());
      on_reply(r);
      log_response(op, r);
      mark_dirty();
    });
    link.refresh_status();
  };
  if (urgent) {
    link.post_stop(std::move(job));
  } else {
    link.post(std::move(job));
  }
}

// Jog: coalesced, so a slow daemon never sees a backlog of old velocities.
void ConsoleServer::Impl::drive(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto linear = m.number("linear");
  const auto angular = m.number("angular");
  if (!linear || !angular) return pages.notice(s, "drive: linear and angular needed");
  // A held jog re-sends every 100 ms: a refusal is shown (last command) and logged once per code
  // and at most every 2 s, not ten times a second.
  link.drive(protocol::Drive{*linear, *angular}, [this](const client::Response& r) {
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
  });
}

void ConsoleServer::Impl::approach(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
  const auto standoff = m.number("standoff_m");
  if (!standoff) return pages.notice(s, "approach: standoff_m needed");
  add_log("sending Approach to " + client::json_number(*standoff) + " m");
  const protocol::Message msg = protocol::Approach{*standoff};
  link.post([this, msg] {
    const auto r = link.client().request(msg);
    const auto json = response_json(r);
    on_io([this, json, r] {
      last_command = JsonObject().add("op", "approach").add("reply", json).add("at", now_hms());
      on_reply(r);
      log_response("approach", r);
      mark_dirty();
    });
    link.refresh_status();
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
