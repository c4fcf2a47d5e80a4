// The console's JSON of ajard's messages (console/src/daemon_json.hpp) is ajarctl's, field for
// field: for the same message, the same object (docs/protocol.md section 10), the console adding
// only "ok" around a reply where ajarctl adds type, command, ok and request_id.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "../../console/src/daemon_json.hpp"
#include "../protocol/samples.hpp"
#include "ajar/client/output.hpp"

namespace ajar::console {
namespace {

using Json = nlohmann::ordered_json;

Json parse(const client::JsonObject& o) {
  return Json::parse(o.str());
}
Json without(Json j, const std::set<std::string>& keys) {
  for (const auto& key : keys) {
    EXPECT_TRUE(j.contains(key)) << key << " in " << j.dump();
    j.erase(key);
  }
  return j;
}

TEST(DaemonJson, TheConsoleAndAjarctlPrintTheSameMessageAlike) {
  std::size_t acks = 0, errors = 0, statuses = 0, telemetry = 0;
  for (std::uint8_t minor = 1; minor <= protocol::kVersionMinor; ++minor) {
    for (const auto& sample : protocol::samples::all()) {
      const protocol::Message& m = sample.envelope.message;
      client::Response r;
      r.outcome = client::CallOutcome::kReply;
      r.request_id = 5;
      r.session_minor = minor;
      r.reply = m;
      const std::string what = sample.name + " 1." + std::to_string(minor);
      if (const auto* ack = std::get_if<protocol::Ack>(&m)) {
        if (protocol::minor_of(ack->acknowledged) > minor) continue;
        EXPECT_EQ(without(parse(response_json(r)), {"ok"}),
                  without(parse(client::response_object("x", r)),
                          {"type", "command", "ok", "request_id"}))
            << what;
        ++acks;
      } else if (const auto* error = std::get_if<protocol::ErrorReply>(&m)) {
        r.outcome = client::CallOutcome::kRefused;
        r.error = *error;
        EXPECT_EQ(without(parse(response_json(r)), {"ok"}),
                  without(parse(client::response_object("x", r)).at("error"), {"number"}))
            << what;
        ++errors;
      } else if (const auto* s = std::get_if<protocol::Status>(&m)) {
        EXPECT_EQ(parse(status_json(*s, minor)),
                  parse(client::response_object("status", r)).at("status"))
            << what;
        ++statuses;
      } else if (const auto* t = std::get_if<protocol::Telemetry>(&m)) {
        EXPECT_EQ(parse(telemetry_json(*t, minor)), parse(client::telemetry_object(*t, minor)))
            << what;
        ++telemetry;
      }
    }
  }
  EXPECT_GE(acks, 5u);  // every Ack body
  EXPECT_GE(errors, 1u);
  EXPECT_GE(statuses, 1u);
  EXPECT_GE(telemetry, 1u);
}

// The page's reply to a step carries the Ack's wire fields, not a renamed copy: the plane's normal
// is {x, y, z}, the wheels left_wheel_rad/right_wheel_rad, as docs/protocol.md 5.x names them.
TEST(DaemonJson, AStepsReplyCarriesTheAcksWireFields) {
  client::Response r;
  r.outcome = client::CallOutcome::kReply;
  r.session_minor = protocol::kVersionMinor;
  protocol::Ack ack;
  ack.acknowledged = protocol::MessageType::kMeasureDoorPlane;
  ack.state = protocol::ProcedureState::kReadyToAlign;
  ack.body = protocol::samples::plane_ack();
  r.reply = ack;
  const Json j = parse(response_json(r));
  EXPECT_TRUE(j.at("ok").get<bool>());
  EXPECT_EQ(j.at("acknowledged"), "MeasureDoorPlane");
  EXPECT_EQ(j.at("state"), "ready_to_align");
  EXPECT_EQ(j.at("normal").at("x").get<double>(), protocol::samples::plane_ack().normal.x());
  EXPECT_EQ(j.at("left_wheel_rad").get<double>(), protocol::samples::plane_ack().left_wheel_rad);
  EXPECT_FALSE(j.contains("values"));
}

}  // namespace
}  // namespace ajar::console
