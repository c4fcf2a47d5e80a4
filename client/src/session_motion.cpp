#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <thread>

#include "session.hpp"

namespace ajar::client {

namespace {

constexpr auto kProgressInterval = Milliseconds{500};

double yaw_turned_rad(const protocol::Status& start, const protocol::Status& now) {
  return std::remainder(now.base_yaw_odometry_rad - start.base_yaw_odometry_rad,
                        2 * std::numbers::pi);
}

// One progress line of align / engage (`command`) into `o`, its text returned: the elapsed time
// and the yaw turned and still to turn (align), or the arm's state (engage).
std::string motion_progress(const std::string& command, bool align, const protocol::Status& start,
                            const protocol::Status& now, double elapsed_s, JsonObject& o) {
  o.add("type", "progress").add("command", command).add("ok", true);
  o.add("elapsed_s", elapsed_s).add("state", protocol::to_string(now.state));
  char text[200];
  if (align) {
    const double turned = yaw_turned_rad(start, now);
    o.add("yaw_turned_rad", turned);
    if (start.has_plane) {
      const double remaining = start.plane.yaw_deviation_rad - turned;
      o.add("yaw_remaining_rad", remaining);
      std::snprintf(text, sizeof text, "%s: %5.1f s, turned %+.4f rad, %+.4f rad (%+.2f deg) to go",
                    command.c_str(), elapsed_s, turned, remaining,
                    remaining * 180 / std::numbers::pi);
    } else {
      std::snprintf(text, sizeof text, "%s: %5.1f s, turned %+.4f rad", command.c_str(), elapsed_s,
                    turned);
    }
  } else {
    o.add("arm_state", protocol::to_string(now.arm_state));
    std::snprintf(text, sizeof text, "%s: %5.1f s, arm %s", command.c_str(), elapsed_s,
                  std::string(protocol::to_string(now.arm_state)).c_str());
  }
  return text;
}

// align's result: the odometry yaw before and after, and what the measured plane commanded.
void add_align_result(const protocol::Status& start, const protocol::Status& last, JsonObject& o,
                      std::string& text) {
  const double turned = yaw_turned_rad(start, last);
  o.add("base_yaw_before_rad", start.base_yaw_odometry_rad)
      .add("base_yaw_after_rad", last.base_yaw_odometry_rad)
      .add("yaw_turned_rad", turned);
  char line[200];
  std::snprintf(line, sizeof line, "\n  odometry yaw: %+.5f -> %+.5f rad (turned %+.5f rad)",
                start.base_yaw_odometry_rad, last.base_yaw_odometry_rad, turned);
  text += line;
  if (start.has_plane) {
    o.add("commanded", ack_body_json(start.plane));  // the PlaneAck's wire fields
    std::snprintf(line, sizeof line, "\n  commanded:    %+.5f rad (wheels %+.5f / %+.5f rad)",
                  start.plane.yaw_deviation_rad, start.plane.left_wheel_rad,
                  start.plane.right_wheel_rad);
    text += line;
  }
}

// Why align / engage did not reach its goal: the latched fault, the state it ended in, or still
// `busy` at --wait-timeout.
void add_motion_failure(const Command& c, const protocol::Status& last, bool finished,
                        protocol::ProcedureState busy, JsonObject& o, std::string& text) {
  std::string code = last.latched_fault != ErrorCode::kOk
                         ? std::string(ajar::to_string(last.latched_fault))
                         : (finished ? std::string("WRONG_STATE") : std::string(kTimeoutCode));
  const std::string message =
      finished ? "the " + c.name + " ended in state " + std::string(protocol::to_string(last.state))
               : "still " + std::string(protocol::to_string(busy)) + " after " +
                     std::to_string(c.wait_timeout_s) + " s: Stop sent";
  o.add("error", error_object(code, "", message));
  text += "\n  " + code + ": " + message;
}

}  // namespace

// The one wait of align, engage and approach: sends the request (events shown), prints the Ack and,
// unless --no-wait, polls the status every 50 ms with the heartbeat on (it feeds the deadman) until
// `done` says the motion is over, printing `progress` every 0.5 s. Ctrl-C sends Stop; so does
// --wait-timeout, which then waits for the Stop's Ack rather than leave the stop to the deadman.
Session::MotionWait Session::send_and_wait(
    const Command& c, const std::function<bool(const protocol::Status&)>& done,
    const std::function<void(const protocol::Status&, double)>& progress) {
  MotionWait w;
  show_events_ = true;
  const Response ack = client_.request(c.request);
  print(response_object(c.name, ack), response_text(c.name, ack));
  if (!ack.ok() || !c.wait) {
    show_events_ = false;
    w.rc = exit_code(ack);
    return w;
  }
  w.waited = true;
  client_.set_heartbeat(Milliseconds{100});
  const auto started = Clock::now();
  const auto deadline = started + seconds_to_ms(c.wait_timeout_s);
  auto next_progress = started + kProgressInterval;
  while (Clock::now() < deadline) {
    if (interrupted()) {
      // Ctrl-C while the robot moves: stop it rather than leave it to the deadman.
      const Response stop = client_.request(protocol::Stop{});
      print(response_object("stop", stop), "interrupted: " + response_text("stop", stop));
      w.rc = kExitRefused;
      break;
    }
    const Response r = client_.request(protocol::GetStatus{});
    if (!r.ok()) {
      print(response_object(c.name, r), response_text(c.name, r));
      w.rc = exit_code(r);
      break;
    }
    w.last = *r.get<protocol::Status>();
    if (done(w.last)) {
      w.finished = true;
      break;
    }
    if (Clock::now() >= next_progress) {
      progress(w.last, std::chrono::duration<double>(Clock::now() - started).count());
      next_progress += kProgressInterval;
    }
    std::this_thread::sleep_for(Milliseconds{50});
  }
  if (!w.finished && w.rc == kExitOk) {
    const Response stop = client_.request(protocol::Stop{});
    print(response_object("stop", stop),
          c.name + " wait timed out: " + response_text("stop", stop));
    if (const Response r = client_.request(protocol::GetStatus{}); r.ok()) {
      w.last = *r.get<protocol::Status>();
    }
  }
  client_.set_heartbeat(Milliseconds{0});
  show_events_ = false;
  return w;
}

// align / engage: send, then (unless --no-wait) wait until the procedure leaves Aligning /
// Engaging. Progress: the elapsed time and, for align, the yaw turned so far and the yaw still to
// turn (the measured plane's yaw minus the odometry yaw turned since the start); for engage, the
// arm's state.
int Session::motion(const Command& c) {
  const bool align = c.kind == Command::Kind::kAlign;
  const Response before = client_.request(protocol::GetStatus{});
  if (!before.ok()) {
    print(response_object(c.name, before), response_text(c.name, before));
    return exit_code(before);
  }
  const protocol::Status start = *before.get<protocol::Status>();
  const auto busy =
      align ? protocol::ProcedureState::kAligning : protocol::ProcedureState::kEngaging;
  const MotionWait w = send_and_wait(
      c, [busy](const protocol::Status& s) { return s.state != busy; },
      [&](const protocol::Status& now, double elapsed_s) {
        JsonObject o;
        const std::string text = motion_progress(c.name, align, start, now, elapsed_s, o);
        print(o, text);
      });
  if (!w.waited || w.rc != kExitOk) return w.rc;

  const protocol::Status& last = w.last;
  const bool finished = w.finished;
  const auto goal = align ? protocol::ProcedureState::kAligned : protocol::ProcedureState::kEngaged;
  const bool ok = finished && last.state == goal;
  JsonObject o;
  o.add("type", align ? "align_result" : "engage_result").add("command", c.name).add("ok", ok);
  o.add("state", protocol::to_string(last.state));
  std::string text = c.name + ": " + (ok ? "done" : "NOT done") + ", state " +
                     std::string(protocol::to_string(last.state));
  if (align) {
    add_align_result(start, last, o, text);
  } else {
    o.add("arm_state", protocol::to_string(last.arm_state));
    text += ", arm " + std::string(protocol::to_string(last.arm_state));
  }
  if (!ok) add_motion_failure(c, last, finished, busy, o, text);
  print(o, text);
  if (ok) return kExitOk;
  return finished ? kExitRefused : kExitConnection;
}

// approach STANDOFF_M: the Ack's move, then (unless --no-wait) wait for the motion's end Event
// (finished, stopped or a fault latched); progress shows the door distance; reports the final
// door distance.
int Session::approach(const Command& c) {
  const double standoff_m = std::get<protocol::Approach>(c.request).standoff_m;
  std::size_t seen = 0;
  {
    std::lock_guard lock(latest_mutex_);
    seen = events_.size();
  }
  std::optional<protocol::EventKind> end;
  const MotionWait w = send_and_wait(
      c,
      [&](const protocol::Status&) {
        std::lock_guard lock(latest_mutex_);
        for (std::size_t i = std::min(seen, events_.size()); i < events_.size(); ++i) {
          const auto kind = events_[i];
          if (kind == protocol::EventKind::kMotionFinished ||
              kind == protocol::EventKind::kMotionStopped ||
              kind == protocol::EventKind::kFaultLatched) {
            end = kind;
          }
        }
        return end.has_value();
      },
      [&](const protocol::Status& s, double elapsed_s) {
        JsonObject o;
        o.add("type", "progress").add("command", c.name).add("ok", true);
        o.add("elapsed_s", elapsed_s).add("state", protocol::to_string(s.state));
        std::string text = c.name + ": " + fixed(elapsed_s, 1) + " s, door ";
        if (s.door.has_distance) {
          o.add("door_distance_m", s.door.distance_m);
          text += fixed(s.door.distance_m, 4) + " m";
        } else {
          text += "unknown";
        }
        text += " (standoff " + fixed(standoff_m, 4) + " m)";
        print(o, text);
      });
  if (!w.waited || w.rc != kExitOk) return w.rc;
  const Response last = client_.request(protocol::GetStatus{});
  const auto* s = last.get<protocol::Status>();
  const bool ok = end == protocol::EventKind::kMotionFinished;
  JsonObject o;
  o.add("type", "approach_result").add("command", c.name).add("ok", ok);
  o.add("outcome", end ? protocol::to_string(*end) : std::string_view("timeout"));
  o.add("standoff_m", standoff_m);
  std::string text = c.name + ": " + (ok ? "done" : "NOT done") + " (" +
                     (end ? std::string(protocol::to_string(*end)) : std::string("timed out")) +
                     ")";
  if (s != nullptr && s->door.has_distance) {
    o.add("door_distance_m", s->door.distance_m)
        .add("standoff_error_m", s->door.distance_m - standoff_m);
    text += ", door " + fixed(s->door.distance_m, 4) + " m from the base (standoff " +
            fixed(standoff_m, 4) + " m, error " + fixed(s->door.distance_m - standoff_m, 4, true) +
            " m)";
  }
  if (s != nullptr && s->latched_fault != ErrorCode::kOk) {
    o.add("error", error_object(ajar::to_string(s->latched_fault), "", "fault latched"));
    text += "\n  fault latched: " + std::string(ajar::to_string(s->latched_fault));
  }
  print(o, text);
  if (ok) return kExitOk;
  return end ? kExitRefused : kExitConnection;
}

}  // namespace ajar::client
