#include "client_impl.hpp"  // first: includes <utility> before Asio

#include <future>
#include <random>

#include "ajar/core/words.hpp"

namespace ajar::client {

std::optional<Endpoint> parse_endpoint(std::string_view text) {
  auto parsed = protocol::parse_host_port(text, protocol::PortZero::kRefused);
  if (!parsed) return std::nullopt;
  return Endpoint{std::move(parsed->host), parsed->port};
}

std::string_view to_string(CallOutcome outcome) noexcept {
  constexpr Word<CallOutcome> kWords[] = {{CallOutcome::kReply, "reply"},
                                          {CallOutcome::kRefused, "refused"},
                                          {CallOutcome::kTimeout, "timeout"},
                                          {CallOutcome::kDisconnected, "disconnected"}};
  return word_of(kWords, outcome);
}

protocol::FramedPoint framed(core::Frame frame, double x_m, double y_m, double z_m) {
  protocol::FramedPoint p;
  p.frame = frame;
  p.position_m = core::Vec3(x_m, y_m, z_m);
  return p;
}

namespace {
std::uint64_t random_instance_id() {
  std::random_device device;
  std::uint64_t id = (static_cast<std::uint64_t>(device()) << 32) ^ device();
  id ^= static_cast<std::uint64_t>(Clock::now().time_since_epoch().count());
  return id == 0 ? 1 : id;
}
}  // namespace

Client::Client(ClientOptions options)
    : options_(std::move(options)),
      instance_id_(options_.client_instance_id != 0 ? options_.client_instance_id
                                                    : random_instance_id()),
      impl_(std::make_unique<Impl>()) {
  impl_->thread = std::thread([impl = impl_.get()] { impl->io.run(); });
}

Client::~Client() {
  {
    std::lock_guard lock(impl_->handler_mutex);
    impl_->event_handler = nullptr;
    impl_->telemetry_handler = nullptr;
    impl_->disconnect_handler = nullptr;
  }
  asio::post(impl_->io, [impl = impl_.get()] {
    impl->heartbeat_timer.cancel();
    impl->on_closed("");
    impl->io.stop();
  });
  impl_->work.reset();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void Client::close() {
  auto promise = std::make_shared<std::promise<void>>();
  auto future = promise->get_future();
  asio::post(impl_->io, [impl = impl_.get(), promise] {
    impl->on_closed("");
    promise->set_value();
  });
  future.wait();
}

bool Client::connected() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->is_connected;
}

Response Client::hello(protocol::Role role, bool take_over) {
  protocol::Hello hello;
  hello.requested_role = role;
  hello.take_over = take_over;
  hello.client_instance_id = instance_id_;
  hello.client_name.assign(options_.client_name);
  Response response = request(hello);
  if (const auto* welcome = response.get<protocol::Welcome>()) {
    std::lock_guard lock(impl_->mutex);
    impl_->welcome = *welcome;
  }
  return response;
}

std::optional<protocol::Welcome> Client::welcome() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->welcome;
}

Response Client::request(const protocol::Message& message, Milliseconds timeout) {
  return request(message, timeout, options_.retries);
}

Response Client::request(const protocol::Message& message, Milliseconds timeout, int retries) {
  if (timeout.count() <= 0) timeout = options_.request_timeout;
  Response response;
  protocol::Envelope envelope;
  envelope.request_id = next_request_id();
  envelope.message = message;
  response.request_id = envelope.request_id;
  if (std::vector<std::uint8_t> probe; !protocol::encode_append(envelope, probe)) {
    // Nothing can be sent (e.g. a MeasureDoorPlane count outside 3..16): refuse here, as the
    // daemon would, rather than send nothing and report a timeout.
    const bool plane = std::holds_alternative<protocol::MeasureDoorPlane>(message);
    response.outcome = CallOutcome::kRefused;
    response.error.code = plane ? ErrorCode::kBadCount : ErrorCode::kInternal;
    response.error.offending_type = protocol::type_of(message);
    response.error.field.assign(plane ? "count" : "");
    response.error.message.assign(
        std::string("not sent: the client cannot encode this ") +
        std::string(protocol::to_string(protocol::type_of(message))) +
        (plane ? " (count must be 3..16, got " +
                     std::to_string(std::get<protocol::MeasureDoorPlane>(message).count) + ")"
               : " request"));
    response.reply = response.error;
    return response;
  }
  for (int attempt = 0; attempt <= std::max(0, retries); ++attempt) {
    envelope.flags = attempt == 0 ? protocol::kFlagNone : protocol::kFlagRetransmit;
    if (!send_envelope(envelope)) {
      response.outcome = CallOutcome::kDisconnected;
      response.transport_error = "not connected";
      return response;
    }
    ++response.attempts;
    const auto sent = Clock::now();
    auto reply = wait_reply(envelope.request_id, timeout);
    if (reply) {
      if (response.attempts > 1) {  // each earlier attempt may still be answered
        std::lock_guard lock(impl_->mutex);
        impl_->forget_request(envelope.request_id, response.attempts - 1);
      }
      response.round_trip = std::chrono::duration_cast<Milliseconds>(Clock::now() - sent);
      response.reply = std::move(reply->message);
      if (const auto w = welcome()) response.session_minor = w->version_minor;
      if (const auto* error = std::get_if<protocol::ErrorReply>(&response.reply)) {
        response.outcome = CallOutcome::kRefused;
        response.error = *error;
      } else {
        response.outcome = CallOutcome::kReply;
      }
      return response;
    }
    if (!connected()) {
      response.outcome = CallOutcome::kDisconnected;
      response.transport_error = "connection lost while waiting for the reply";
      return response;
    }
  }
  {  // every attempt may still be answered later
    std::lock_guard lock(impl_->mutex);
    impl_->forget_request(envelope.request_id, response.attempts);
  }
  response.outcome = CallOutcome::kTimeout;
  response.transport_error =
      "no reply to " + std::string(protocol::to_string(protocol::type_of(message))) + " within " +
      std::to_string(timeout.count()) + " ms (" + std::to_string(response.attempts) + " attempts)";
  return response;
}

void Client::set_heartbeat(Milliseconds interval) {
  asio::post(impl_->io, [impl = impl_.get(), interval] {
    impl->heartbeat_interval = interval;
    impl->heartbeat_timer.cancel();
    impl->schedule_heartbeat();
  });
}

void Client::on_event(EventHandler handler) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->event_handler = std::move(handler);
}
void Client::on_telemetry(TelemetryHandler handler) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->telemetry_handler = std::move(handler);
}
void Client::on_disconnect(DisconnectHandler handler) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->disconnect_handler = std::move(handler);
}

std::uint32_t Client::next_request_id() {
  std::uint32_t id = impl_->next_id.fetch_add(1);
  if (id == 0) id = impl_->next_id.fetch_add(1);
  return id;
}

bool Client::send_raw(std::span<const std::uint8_t> bytes) {
  if (!connected()) return false;
  asio::post(impl_->io, [impl = impl_.get(),
                         data = std::vector<std::uint8_t>(bytes.begin(), bytes.end())]() mutable {
    impl->write(std::move(data));
  });
  return true;
}

bool Client::send_envelope(const protocol::Envelope& envelope) {
  std::vector<std::uint8_t> bytes;
  if (!protocol::encode_append(envelope, bytes)) return false;
  return send_raw(bytes);
}

std::optional<protocol::Envelope> Client::wait_reply(std::optional<std::uint32_t> request_id,
                                                     Milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  std::unique_lock lock(impl_->mutex);
  std::optional<protocol::Envelope> found;
  impl_->changed.wait_until(lock, deadline, [&] {
    auto& replies = impl_->replies;
    for (auto it = replies.begin(); it != replies.end(); ++it) {
      if (!request_id || it->request_id == *request_id) {
        found = std::move(*it);
        replies.erase(it);
        return true;
      }
    }
    return !impl_->is_connected;
  });
  return found;
}

bool Client::wait_closed(Milliseconds timeout) {
  std::unique_lock lock(impl_->mutex);
  return impl_->changed.wait_for(lock, timeout, [&] { return !impl_->is_connected; });
}

void Client::discard_replies() {
  std::lock_guard lock(impl_->mutex);
  impl_->replies.clear();
}

void Client::record_headers(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->recording_headers = on;
  if (on) impl_->headers.clear();
}

std::vector<protocol::FrameHeader> Client::recorded_headers() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->headers;
}

}  // namespace ajar::client
