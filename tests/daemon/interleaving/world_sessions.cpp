// The interleaving world's sessions: links connect, read several frames in one engine batch,
// and get exactly one reply per request in order (world.hpp).
#include "world.hpp"

#include "det_mock_card.hpp"
#include "fake_door.hpp"
#include "fake_engine_fixture.hpp"

namespace ajar::testing::interleaving {

FakeLink* World::connect(protocol::Role role, bool take_over, std::uint64_t instance) {
  links_.push_back(std::make_unique<FakeLink>(next_link_id_++, instance));
  FakeLink* link = links_.back().get();
  hub_->on_open(*link);
  protocol::Hello hello;
  hello.requested_role = role;
  hello.take_over = take_over;
  hello.client_instance_id = instance;
  hello.client_name = "interleave";
  read(*link, {protocol::Message{hello}});
  return link;
}

void World::disconnect(FakeLink* link, const char* why) {
  drain(*link);
  hub_->on_closed(*link, why);
  if (controller_ == link) controller_ = nullptr;
  if (observer_ == link) observer_ = nullptr;
  for (auto it = links_.begin(); it != links_.end(); ++it) {
    if (it->get() == link) {
      links_.erase(it);
      break;
    }
  }
}

void World::read(FakeLink& link, const std::vector<Frame>& frames) {
  hub_->on_read_begin(link);
  for (const auto& f : frames) {
    if (!violation_.empty()) break;
    deliver(link, f);
  }
  hub_->on_read_end(link);
  check_now();
  drain(link);
}

void World::read(FakeLink& link, std::initializer_list<protocol::Message> messages) {
  std::vector<Frame> frames;
  for (const auto& m : messages)
    frames.push_back({m, false, 0});
  read(link, frames);
}

void World::deliver(FakeLink& link, const Frame& f) {
  ++tick_;
  const MessageType type = protocol::type_of(f.message);
  const auto original = f.repeat ? sent_.find(f.request_id) : sent_.end();
  const bool repeat = original != sent_.end() && link.instance != 0 &&
                      original->second.link_instance == link.instance;
  // Request ids are never reused by a client (also across its reconnects): one counter.
  const std::uint32_t rid = repeat ? f.request_id : next_request_++;
  const Sent first = repeat ? original->second : Sent{};
  const auto before = engine_->status();
  const int executions = recorder_->executions();
  const bool nothing_pending = link.expected.empty();
  link.expected.push_back({rid, std::nullopt, true});
  hub_->on_message(link, protocol::Envelope{rid, 0, f.message});
  const bool executed = recorder_->executions() != executions;
  if (nothing_pending && (type == MessageType::kStop || type == MessageType::kEmergencyStop) &&
      !has_reply(link, rid)) {
    return fail("a Stop/EmergencyStop Ack was held (only a save-changing reply may wait)");
  }
  std::ostringstream line;
  line << "session " << link.id() << (&link == controller_ ? " (controller)" : "") << ": "
       << (repeat ? "repeat " : "") << protocol::to_string(type) << " #" << rid;
  const bool is_stop = type == MessageType::kStop || type == MessageType::kEmergencyStop ||
                       type == MessageType::kReset;
  const bool from_controller = &link == controller_;
  if (!executed) {
    line << " not executed";
    note(line.str());
    if (repeat && type != MessageType::kStop && type != MessageType::kEmergencyStop) {
      coverage_.bump("duplicate executed once");
      link.expected.back().reply = first.reply;  // the recorded reply, sent again
    }
    if (is_stop && type != MessageType::kReset && link.closed == false) {
      fail("a Stop/EmergencyStop did not reach the engine");
    }
    if (from_controller && !repeat && type != MessageType::kHello && type != MessageType::kPing &&
        type != MessageType::kGetStatus) {
      fail("a controller command did not reach the engine");
    }
    return;
  }
  if (repeat && type != MessageType::kStop && type != MessageType::kEmergencyStop) {
    // Executed again: only allowed when the first one was not recorded (QUEUE_FULL).
    const auto* e = std::get_if<protocol::ErrorReply>(&first.reply);
    if (e == nullptr || e->code != ErrorCode::kQueueFull) {
      return fail("a repeated request (same client instance and request id) executed twice");
    }
  }
  if (!from_controller && type != MessageType::kStop && type != MessageType::kEmergencyStop) {
    return fail(std::string("a ") + std::string(protocol::to_string(type)) +
                " from a session that is not the controller reached the engine");
  }
  const protocol::Message reply = recorder_->last_reply();
  link.expected.back().reply = reply;
  sent_[rid] = {link.instance, f.message, reply};
  last_request_ = rid;
  on_executed(f.message, reply, before, line);
}

void World::drain(FakeLink& link) {
  for (const auto& frame : link.frames) {
    const auto out = protocol::decode_frame(*frame);
    if (out.kind != protocol::StreamDecoder::Kind::kMessage) {
      return fail("the hub sent a frame that does not decode");
    }
    const auto& env = out.envelope;
    if (env.request_id == 0) continue;  // events, telemetry
    if (link.expected.empty() || link.expected.front().request_id != env.request_id) {
      return fail("a reply out of request order, or one nobody asked for (request " +
                  std::to_string(env.request_id) + ")");
    }
    const auto want = link.expected.front().reply;
    if (!link.expected.front().immediate) coverage_.bump("durable ack held");
    link.expected.pop_front();
    if (want && !protocol::wire_equal(*want, env.message)) {
      return fail("the reply to request " + std::to_string(env.request_id) +
                  " is not what the engine answered (or what was recorded for it)");
    }
  }
  link.frames.clear();
  for (auto& e : link.expected)
    e.immediate = false;
}

bool World::has_reply(const FakeLink& link, std::uint32_t request_id) {
  for (const auto& frame : link.frames) {
    const auto out = protocol::decode_frame(*frame);
    if (out.kind == protocol::StreamDecoder::Kind::kMessage &&
        out.envelope.request_id == request_id)
      return true;
  }
  return false;
}

void World::drain_all() {
  for (auto& l : links_)
    drain(*l);
}

}  // namespace ajar::testing::interleaving
