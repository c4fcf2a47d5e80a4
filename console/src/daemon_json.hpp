// What ajard says, as the JSON the page reads (docs/console.md): a request's reply, the daemon's
// Status and a Telemetry sample. The message itself is client::message_json(), the one JSON shape
// ajarctl --json prints too (docs/protocol.md section 10: wire names, nested blocks as objects,
// enums as words); the console only adds its own keys around it ("ok", "type"), never renames a
// field.
#pragma once

#include "ajar/client/client.hpp"
#include "ajar/client/json.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::console {

// {"ok":true, then the Ack's fields: acknowledged, state, its body's fields} or {"ok":false, then
// the Error's fields: code, offending_type, field, message}; a transport failure is {"ok":false,
// "code": client::to_string(outcome), "field":"", "message"}.
client::JsonObject response_json(const client::Response& r);

// The daemon's Status in protocol 1.`minor` (the session's): exactly client::message_json().
client::JsonObject status_json(const protocol::Status& s, std::uint8_t minor);

// {"type":"telemetry", then the sample's fields}: exactly ajarctl's telemetry line.
client::JsonObject telemetry_json(const protocol::Telemetry& t, std::uint8_t minor);

}  // namespace ajar::console
