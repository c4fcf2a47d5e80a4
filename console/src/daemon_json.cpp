#include "daemon_json.hpp"

#include "ajar/client/output.hpp"

namespace ajar::console {

using client::JsonObject;

JsonObject response_json(const client::Response& r) {
  JsonObject o;
  if (r.outcome == client::CallOutcome::kReply) {
    o.add("ok", true);
    if (r.get<protocol::Ack>() != nullptr) o.merge(client::message_json(r.reply, r.session_minor));
    return o;
  }
  o.add("ok", false);
  if (r.outcome == client::CallOutcome::kRefused) {
    o.merge(client::message_json(r.error, r.session_minor));
  } else {
    o.add("code", client::to_string(r.outcome));
    o.add("field", "");
    o.add("message", r.transport_error);
  }
  return o;
}

JsonObject status_json(const protocol::Status& s, std::uint8_t minor) {
  return client::message_json(s, minor);
}

JsonObject telemetry_json(const protocol::Telemetry& t, std::uint8_t minor) {
  return client::telemetry_object(t, minor);
}

}  // namespace ajar::console
