// ajarctl --json renderings (output.hpp): a reply's, event's or telemetry sample's own keys (type,
// command, ok, request_id) around the message's JSON, which message_json() generates from the
// message tables (docs/protocol.md section 10: the one JSON shape of ajarctl and the console).
#include "ajar/client/output.hpp"

namespace ajar::client {

JsonObject loop_object(const protocol::LoopStatistics& loop) {
  protocol::Telemetry t;
  t.loop = loop;
  return message_json(t).member("loop");
}

JsonObject error_object(std::string_view code, std::string_view field, std::string_view message) {
  JsonObject o;
  o.add("code", code).add("field", field).add("message", message);
  return o;
}

JsonObject error_object(const protocol::ErrorReply& error) {
  JsonObject o = message_json(error);
  o.add("number", static_cast<unsigned>(error.code));  // not a wire word: the code's number
  return o;
}

JsonObject recorder_object(const protocol::RecorderState& r) {
  protocol::Status s;
  s.recorder = r;
  return message_json(s).member("recorder");
}

JsonObject status_object(const protocol::Status& s, std::uint8_t session_minor) {
  return message_json(s, session_minor);
}

JsonObject welcome_object(const protocol::Welcome& w) {
  return message_json(w);
}

JsonObject robot_model_object(const protocol::RobotModel& model) {
  return message_json(model);
}

JsonObject response_object(std::string_view command, const Response& r) {
  JsonObject o;
  switch (r.outcome) {
    case CallOutcome::kTimeout:
    case CallOutcome::kDisconnected:
      o.add("type", "error").add("command", command).add("ok", false);
      o.add("error",
            error_object(r.outcome == CallOutcome::kTimeout ? kTimeoutCode : kDisconnectedCode, "",
                         r.transport_error));
      return o;
    case CallOutcome::kRefused:
      o.add("type", "error").add("command", command).add("ok", false);
      o.add("request_id", static_cast<unsigned>(r.request_id));
      o.add("error", error_object(r.error));
      return o;
    case CallOutcome::kReply:
      break;
  }
  const std::uint8_t minor = r.session_minor;
  if (r.get<protocol::Ack>() != nullptr) {
    o.add("type", "ack").add("command", command).add("ok", true);
    o.add("request_id", static_cast<unsigned>(r.request_id));
    o.merge(message_json(r.reply, minor));  // acknowledged, state, the body's fields
  } else if (r.get<protocol::RobotModel>() != nullptr) {
    o.add("type", "robot_model").add("command", command).add("ok", true);
    o.add("robot_model", message_json(r.reply, minor));
  } else if (r.get<protocol::Status>() != nullptr) {
    o.add("type", "status").add("command", command).add("ok", true);
    o.add("status", message_json(r.reply, minor));
  } else if (r.get<protocol::Pong>() != nullptr) {
    o.add("type", "pong").add("command", command).add("ok", true);
    o.merge(message_json(r.reply, minor));  // client_time_ns, daemon_time_ns
  } else if (r.get<protocol::Welcome>() != nullptr) {
    o.add("type", "welcome").add("command", command).add("ok", true);
    o.add("welcome", message_json(r.reply, minor));
  } else {
    o.add("type", "reply").add("command", command).add("ok", true);
    o.add("message", protocol::to_string(protocol::type_of(r.reply)));
  }
  return o;
}

JsonObject event_object(const protocol::Event& e, std::uint8_t minor) {
  return JsonObject().add("type", "event").merge(message_json(e, minor));
}

JsonObject telemetry_object(const protocol::Telemetry& t, std::uint8_t minor) {
  return JsonObject().add("type", "telemetry").merge(message_json(t, minor));
}

}  // namespace ajar::client
