// The client library against an in-test fake daemon (Asio on 127.0.0.1 port 0): handshake,
// request ids, retries with the same id, refusals, events/telemetry callbacks, heartbeat,
// disconnects and reconnects. No timing is asserted: waits are bounded, outcomes are checked.
#include <utility>  // before Asio

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <sstream>
#include <thread>

#include <boost/asio.hpp>
#include <gtest/gtest.h>

#include "ajar/client/cli.hpp"
#include "ajar/client/client.hpp"
#include "fake_daemon.hpp"

namespace ajar::client {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using fake::FakeDaemon;
using fake::polite;
using protocol::MessageType;

ClientOptions fast_options() {
  ClientOptions o;
  o.request_timeout = Milliseconds{300};
  o.connect_timeout = Milliseconds{3000};
  o.retries = 0;
  return o;
}

TEST(Client, HelloCarriesRoleInstanceIdAndName) {
  FakeDaemon daemon(polite);
  ClientOptions o = fast_options();
  o.client_instance_id = 0xABCDEF;
  o.client_name = "door-gui 2.3";
  Client c(o);
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  EXPECT_TRUE(c.connected());
  const Response r = c.hello(protocol::Role::kController, true);
  ASSERT_TRUE(r.ok()) << r.transport_error;
  ASSERT_TRUE(c.welcome());
  EXPECT_EQ(c.welcome()->granted_role, protocol::Role::kController);
  const auto got = daemon.received();
  ASSERT_EQ(got.size(), 1u);
  const auto& hello = std::get<protocol::Hello>(got[0].message);
  EXPECT_EQ(hello.client_instance_id, 0xABCDEFu);
  EXPECT_EQ(hello.client_name.view(), "door-gui 2.3");
  EXPECT_TRUE(hello.take_over);
  EXPECT_EQ(hello.requested_role, protocol::Role::kController);
}

TEST(Client, RequestsGetIncreasingIdsAndTheirOwnReplies) {
  FakeDaemon daemon(polite);
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  const Response a = c.request(protocol::Ping{11});
  const Response b = c.request(protocol::GetStatus{});
  ASSERT_TRUE(a.get<protocol::Pong>());
  EXPECT_EQ(a.get<protocol::Pong>()->client_time_ns, 11u);
  EXPECT_TRUE(b.get<protocol::Status>());
  EXPECT_GT(b.request_id, a.request_id);
  EXPECT_NE(a.request_id, 0u);
  EXPECT_EQ(a.attempts, 1);
}

TEST(Client, TimeoutIsRetriedWithTheSameIdAndTheRetransmitFlag) {
  std::atomic<int> pings{0};
  FakeDaemon daemon([&](const protocol::Envelope& e) -> std::vector<protocol::Envelope> {
    if (std::holds_alternative<protocol::Ping>(e.message) && pings.fetch_add(1) == 0) return {};
    return polite(e);
  });
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  const Response r = c.request(protocol::Ping{5}, Milliseconds{300}, 2);
  ASSERT_TRUE(r.ok()) << r.transport_error;
  EXPECT_EQ(r.attempts, 2);
  const auto got = daemon.received();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].request_id, got[1].request_id);
  EXPECT_EQ(got[0].flags, protocol::kFlagNone);
  EXPECT_EQ(got[1].flags, protocol::kFlagRetransmit);
}

// The first attempt's reply arrives late, together with the retransmit's: the request takes one,
// and the other is never handed to a later wait_reply() as if it answered something else.
TEST(Client, ALateDuplicateReplyIsDroppedNotKeptForTheNextWait) {
  std::atomic<int> pings{0};
  FakeDaemon daemon([&](const protocol::Envelope& e) -> std::vector<protocol::Envelope> {
    if (!std::holds_alternative<protocol::Ping>(e.message)) return polite(e);
    if (pings.fetch_add(1) == 0) return {};  // the first attempt "is slow"
    auto replies = polite(e);
    replies.push_back(replies.front());  // ... and its reply comes with the retransmit's
    return replies;
  });
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  const Response r = c.request(protocol::Ping{5}, Milliseconds{300}, 2);
  ASSERT_TRUE(r.ok()) << r.transport_error;
  EXPECT_EQ(r.attempts, 2);
  EXPECT_FALSE(c.wait_reply(std::nullopt, Milliseconds{300}).has_value());
  const Response status = c.request(protocol::GetStatus{});
  EXPECT_TRUE(status.get<protocol::Status>());
}

TEST(Client, NoReplyAfterAllRetriesIsATimeout) {
  FakeDaemon daemon([](const protocol::Envelope&) { return std::vector<protocol::Envelope>{}; });
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  const Response r = c.request(protocol::GetStatus{}, Milliseconds{100}, 1);
  EXPECT_EQ(r.outcome, CallOutcome::kTimeout);
  EXPECT_EQ(r.attempts, 2);
  EXPECT_FALSE(r.transport_error.empty());
}

// A request the codec cannot encode (here a plane with 2 points) is refused on the spot, naming
// the field, instead of being "sent" as nothing and reported as a daemon timeout.
TEST(Client, UnencodableRequestIsRefusedLocallyNotTimedOut) {
  FakeDaemon daemon(polite);
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  protocol::MeasureDoorPlane plane;
  plane.count = 2;
  const Response r = c.request(plane, Milliseconds{100}, 1);
  EXPECT_EQ(r.outcome, CallOutcome::kRefused);
  EXPECT_EQ(r.error.code, ErrorCode::kBadCount);
  EXPECT_EQ(r.error.field.view(), "count");
  EXPECT_EQ(r.error.offending_type, MessageType::kMeasureDoorPlane);
  EXPECT_NE(r.error.message.view().find("not sent"), std::string_view::npos);
  EXPECT_EQ(r.attempts, 0);
  // Nothing went out; the session still works.
  ASSERT_TRUE(c.request(protocol::Ping{1}).ok());
  EXPECT_EQ(daemon.count(MessageType::kMeasureDoorPlane), 0u);
  // The low-level sender says so too.
  EXPECT_FALSE(c.send_envelope(protocol::Envelope{9, 0, plane}));
}

TEST(Client, ErrorReplyIsARefusalWithItsCodeAndField) {
  FakeDaemon daemon([](const protocol::Envelope& e) {
    protocol::ErrorReply err;
    err.code = ErrorCode::kNotController;
    err.offending_type = protocol::type_of(e.message);
    err.field = "role";
    return std::vector<protocol::Envelope>{{e.request_id, 0, err}};
  });
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  const Response r = c.request(protocol::AlignBase{});
  EXPECT_EQ(r.outcome, CallOutcome::kRefused);
  EXPECT_EQ(r.error.code, ErrorCode::kNotController);
  EXPECT_EQ(r.error.field.view(), "role");
  EXPECT_FALSE(r.ok());
}

TEST(Client, EventsAndTelemetryReachTheCallbacksNotTheReplies) {
  FakeDaemon daemon([](const protocol::Envelope& e) {
    auto replies = polite(e);
    if (std::holds_alternative<protocol::Subscribe>(e.message)) {
      protocol::Event ev;
      ev.kind = protocol::EventKind::kMotionFinished;
      protocol::Telemetry t;
      t.left_counts = 42;
      replies.insert(replies.begin(), {{0, 0, ev}, {0, 0, t}});
    }
    return replies;
  });
  // The callbacks' state is declared before the client, which joins its I/O thread first.
  std::mutex m;
  std::condition_variable cv;
  int events = 0, samples = 0;
  std::int64_t counts = 0;
  Client c(fast_options());
  c.on_event([&](const protocol::Event& e) {
    std::lock_guard lock(m);
    events += e.kind == protocol::EventKind::kMotionFinished ? 1 : 0;
    cv.notify_all();
  });
  c.on_telemetry([&](const protocol::Telemetry& t) {
    std::lock_guard lock(m);
    ++samples;
    counts = t.left_counts;
    cv.notify_all();
  });
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  const Response r = c.request(protocol::Subscribe{10.0f});
  ASSERT_TRUE(r.get<protocol::Ack>());  // the reply, not the Event that came first
  std::unique_lock lock(m);
  ASSERT_TRUE(
      cv.wait_for(lock, std::chrono::seconds(10), [&] { return events == 1 && samples == 1; }));
  EXPECT_EQ(counts, 42);
}

TEST(Client, HeartbeatSendsPingsAndSwallowsTheirPongs) {
  FakeDaemon daemon(polite);
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  c.set_heartbeat(Milliseconds{10});
  EXPECT_TRUE(daemon.wait_for([](const auto& got) { return got.size() >= 3; }));
  c.set_heartbeat(Milliseconds{0});
  for (const auto& e : daemon.received())
    EXPECT_TRUE(std::holds_alternative<protocol::Ping>(e.message));
  EXPECT_FALSE(c.wait_reply(std::nullopt, Milliseconds{50}));  // no stray Pong queued
  EXPECT_TRUE(c.request(protocol::GetStatus{}).get<protocol::Status>());
}

TEST(Client, ADroppedConnectionIsReportedAndReconnectKeepsTheInstance) {
  FakeDaemon daemon(polite);
  std::atomic<int> drops{0};
  Client c(fast_options());
  c.on_disconnect([&](const std::string&) { ++drops; });
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  ASSERT_TRUE(c.hello(protocol::Role::kObserver).ok());
  const std::uint32_t first_id = c.request(protocol::Ping{}).request_id;
  daemon.close_all();
  EXPECT_TRUE(c.wait_closed(Milliseconds{10000}));
  EXPECT_FALSE(c.connected());
  EXPECT_EQ(c.request(protocol::Ping{}).outcome, CallOutcome::kDisconnected);
  // The callback runs on the I/O thread right after the state changed: wait for it (bounded).
  for (int i = 0; i < 1000 && drops.load() == 0; ++i)
    std::this_thread::sleep_for(Milliseconds{10});
  EXPECT_EQ(drops.load(), 1);

  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  ASSERT_TRUE(c.hello(protocol::Role::kObserver).ok());
  const Response again = c.request(protocol::Ping{});
  ASSERT_TRUE(again.ok());
  EXPECT_GT(again.request_id, first_id);
  std::vector<std::uint64_t> ids;
  for (const auto& e : daemon.received()) {
    if (const auto* h = std::get_if<protocol::Hello>(&e.message))
      ids.push_back(h->client_instance_id);
  }
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_EQ(ids[0], ids[1]);
  EXPECT_NE(ids[0], 0u);
}

TEST(Client, ConnectionRefusedIsReported) {
  std::uint16_t port = 0;
  {
    asio::io_context io;
    tcp::acceptor a(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    port = a.local_endpoint().port();
  }
  Client c(fast_options());
  const auto connected = c.connect(Endpoint{"127.0.0.1", port});
  ASSERT_FALSE(connected.ok());
  EXPECT_EQ(connected.error().field, "endpoint");
  EXPECT_NE(connected.error().message.find("cannot connect to 127.0.0.1:"), std::string::npos)
      << connected.error().message;
  EXPECT_FALSE(c.connected());
  EXPECT_EQ(c.request(protocol::Ping{}).outcome, CallOutcome::kDisconnected);
}

TEST(Client, InstanceIdsAreRandomPerClientUnlessGiven) {
  Client a(fast_options()), b(fast_options());
  EXPECT_NE(a.client_instance_id(), 0u);
  EXPECT_NE(a.client_instance_id(), b.client_instance_id());
  ClientOptions o;
  o.client_instance_id = 77;
  EXPECT_EQ(Client(o).client_instance_id(), 77u);
}

TEST(Client, RawBytesAndWaitReplyForConformanceWork) {
  FakeDaemon daemon(polite);
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  std::vector<std::uint8_t> bytes;
  ASSERT_TRUE(protocol::encode_append({4242, 0, protocol::Ping{3}}, bytes));
  for (std::uint8_t byte : bytes)
    ASSERT_TRUE(c.send_raw(std::span<const std::uint8_t>(&byte, 1)));
  const auto reply = c.wait_reply(4242, Milliseconds{10000});
  ASSERT_TRUE(reply);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(reply->message));
}

// Conformance reads the layout the daemon wrote: every received frame's header, in order, also
// when frames arrive split or several in one read.
TEST(Client, RecordedHeadersFollowTheFrameBoundaries) {
  FakeDaemon daemon(polite);
  Client c(fast_options());
  ASSERT_TRUE(c.connect(daemon.endpoint()).ok());
  ASSERT_TRUE(c.request(protocol::Ping{1}).ok());  // not recorded: before record_headers
  c.record_headers(true);
  ASSERT_TRUE(c.request(protocol::GetStatus{}).ok());
  ASSERT_TRUE(c.request(protocol::Ping{2}).ok());
  daemon.push({0, 0, protocol::Telemetry{}});
  daemon.push({0, 0, protocol::Event{}});
  ASSERT_TRUE(c.request(protocol::GetStatus{}).ok());  // after the pushed frames
  const auto headers = c.recorded_headers();
  ASSERT_EQ(headers.size(), 5u);
  // This version's payload lengths (1.2 appended fields to Status, Telemetry and Event): what
  // the codec writes.
  const auto length = [](const protocol::Message& m) {
    std::vector<std::uint8_t> bytes;
    EXPECT_TRUE(protocol::encode_append(protocol::Envelope{0, 0, m}, bytes));
    return static_cast<std::uint32_t>(bytes.size() - protocol::kHeaderSize);
  };
  const std::pair<MessageType, std::uint32_t> expected[] = {
      {MessageType::kStatus, length(protocol::Status{})},
      {MessageType::kPong, 16},
      {MessageType::kTelemetry, length(protocol::Telemetry{})},
      {MessageType::kEvent, length(protocol::Event{})},
      {MessageType::kStatus, length(protocol::Status{})}};
  for (std::size_t i = 0; i < headers.size(); ++i) {
    EXPECT_EQ(headers[i].type, static_cast<std::uint16_t>(expected[i].first)) << i;
    EXPECT_EQ(headers[i].payload_length, expected[i].second) << i;
    EXPECT_EQ(headers[i].version_minor, protocol::kVersionMinor) << i;
  }
  c.record_headers(false);
  ASSERT_TRUE(c.request(protocol::Ping{3}).ok());
  EXPECT_EQ(c.recorded_headers().size(), 5u) << "nothing recorded once off";
}

// `ajarctl align --wait-timeout`: the base is still turning when the wait ends. ajarctl sends Stop
// and waits for its Ack before it disconnects (not leaving the stop to the deadman).
TEST(Ajarctl, AlignWaitTimeoutSendsStopAndWaitsForItsAck) {
  std::atomic<bool> stopped{false};
  FakeDaemon daemon([&](const protocol::Envelope& e) -> std::vector<protocol::Envelope> {
    const auto type = protocol::type_of(e.message);
    if (type == MessageType::kGetStatus) {
      protocol::Status status;
      status.state =
          stopped ? protocol::ProcedureState::kReadyToAlign : protocol::ProcedureState::kAligning;
      return {{e.request_id, 0, status}};
    }
    if (type == MessageType::kStop) stopped = true;
    if (type == MessageType::kAlignBase || type == MessageType::kStop) {
      return {{e.request_id, 0,
               protocol::Ack{type, protocol::ProcedureState::kAligning, protocol::EmptyAck{}}}};
    }
    return polite(e);
  });
  const std::vector<std::string> args{"--connect", "127.0.0.1:" + std::to_string(daemon.port()),
                                      "align", "--wait-timeout", "0.3"};
  std::istringstream in;
  std::ostringstream out, err;
  const int rc = run_ajarctl(args, in, out, err);
  EXPECT_NE(rc, 0) << out.str();
  EXPECT_EQ(daemon.count(MessageType::kStop), 1u) << out.str() << err.str();
  EXPECT_NE(out.str().find("Stop sent"), std::string::npos) << out.str();
  // Stop was the last command, and the status was read again after its Ack.
  const auto got = daemon.received();
  std::size_t stop_at = got.size();
  for (std::size_t i = 0; i < got.size(); ++i)
    if (protocol::type_of(got[i].message) == MessageType::kStop) stop_at = i;
  ASSERT_LT(stop_at, got.size());
  for (std::size_t i = stop_at + 1; i < got.size(); ++i) {
    const auto type = protocol::type_of(got[i].message);
    EXPECT_TRUE(type == MessageType::kGetStatus || type == MessageType::kPing)
        << protocol::to_string(type);
  }
}

}  // namespace
}  // namespace ajar::client
