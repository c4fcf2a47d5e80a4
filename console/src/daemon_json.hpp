// What ajard says, as the JSON the page reads (docs/console.md): a request's reply, the daemon's
// Status and a Telemetry sample. Key names are the wire fields' names; errors and enums are their
// upper-case words (ajar::to_string, protocol::to_string).
#pragma once

#include "ajar/client/client.hpp"
#include "ajar/client/json.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::console {

// {"ok":true,"state":"...","values":{...}} (values: the Ack's span, plane or contact, when it has
// one) or {"ok":false,"code":"POINTS_COLLINEAR","field":"points[2]","message":"..."}; a transport
// failure's code is client::to_string(outcome), its field empty.
client::JsonObject response_json(const client::Response& r);

// The daemon's Status: state, latched fault, the accepted parameters present, drivers, loop.
client::JsonObject status_json(const protocol::Status& s);

// {"type":"telemetry",...}: one sample as the page's gauges read it (t_s in seconds).
client::JsonObject telemetry_json(const protocol::Telemetry& t);

}  // namespace ajar::console
