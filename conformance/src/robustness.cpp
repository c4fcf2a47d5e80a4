// Exactly-once execution, latched faults, and garbage that must not hurt other sessions.
#include "suite.hpp"

#include <random>

namespace ajar::conformance {

// ---- exactly-once execution ----
void Suite::duplicates() {
  check("duplicates: a repeated request id is answered identically and not executed again", [&] {
    auto c = greeted(Role::kController, true);
    if (!c) return std::string("cannot connect");
    const protocol::MeasureDoorWidth first{base_point(1, 0.45, 0.3), base_point(1, -0.45, 0.3)};
    const protocol::MeasureDoorWidth second{base_point(1, 0.40, 0.3), base_point(1, -0.40, 0.3)};
    const std::uint32_t id1 = c->next_request_id();
    const std::uint32_t id2 = c->next_request_id();
    c->send_envelope(protocol::Envelope{id1, 0, first});
    auto r1 = c->wait_reply(id1, timeout());
    c->send_envelope(protocol::Envelope{id2, 0, second});
    auto r2 = c->wait_reply(id2, timeout());
    if (!r1 || !r2) return std::string("no replies");
    c->send_envelope(protocol::Envelope{id1, protocol::kFlagRetransmit, first});
    auto again = c->wait_reply(id1, timeout());
    if (!again || !protocol::wire_equal(again->message, r1->message)) {
      return "repeat answered differently: " + describe(again);
    }
    auto s = status(*c);
    if (!s || !s->has_width || !near(s->width.length_m, 0.8, 1e-9)) {
      return std::string("the repeat was executed again (stored width is not the second one)");
    }
    // Over a new connection of the same client instance.
    c->close();
    if (!c->connect(options_.endpoint)) return std::string("cannot reconnect");
    if (!c->hello(Role::kController, true).ok()) return std::string("Hello after reconnect");
    c->send_envelope(protocol::Envelope{id1, protocol::kFlagRetransmit, first});
    auto after = c->wait_reply(id1, timeout());
    if (!after || !protocol::wire_equal(after->message, r1->message)) {
      return "repeat after reconnect answered differently: " + describe(after);
    }
    s = status(*c);
    if (!s || !near(s->width.length_m, 0.8, 1e-9)) {
      return std::string("the repeat after reconnect was executed again");
    }
    return std::string{};
  });
}

// ---- latched faults ----
void Suite::faults() {
  check("faults: EmergencyStop latches EMERGENCY_STOPPED; commands get FAULT_LATCHED; Reset clears",
        [&] {
          auto c = greeted(Role::kController, true);
          if (!c) return std::string("cannot connect");
          if (auto e = want<protocol::Ack>(c->request(protocol::EmergencyStop{})); !e.empty()) {
            return e;
          }
          auto s = status(*c);
          if (!s || s->state != ProcedureState::kFault ||
              s->latched_fault != ErrorCode::kEmergencyStopped) {
            return std::string("no EMERGENCY_STOPPED fault latched");
          }
          if (auto e = want_error(c->request(protocol::MeasureDoorWidth{base_point(1, 0.45, 0.3),
                                                                        base_point(1, -0.45, 0.3)}),
                                  ErrorCode::kFaultLatched);
              !e.empty()) {
            return e;
          }
          if (auto e = want<protocol::Ack>(c->request(protocol::Reset{false})); !e.empty())
            return e;
          s = status(*c);
          if (!s || s->latched_fault != ErrorCode::kOk || s->state == ProcedureState::kFault) {
            return std::string("Reset did not clear the fault");
          }
          return std::string{};
        });
  moving("faults: the controller leaving during motion stops it and latches DEADMAN", [&] {
    auto watcher = greeted(Role::kObserver);
    {
      auto c = greeted(Role::kController, true);
      if (!c || !watcher) return std::string("cannot connect");
      (void)c->request(protocol::Reset{true});
      (void)c->request(
          protocol::MeasureDoorWidth{base_point(1, 0.45, 0.3), base_point(1, -0.45, 0.3)});
      (void)c->request(
          protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)});
      if (auto e = want_ack(c->request(door_plane(0.6, 1.5)), ProcedureState::kReadyToAlign);
          !e.empty()) {
        return "plane: " + e;
      }
      c->send_envelope(protocol::Envelope{c->next_request_id(), 0, protocol::AlignBase{}});
      c->close();  // gone mid-motion
    }
    const auto deadline = Clock::now() + Milliseconds{5000};
    while (Clock::now() < deadline) {
      const auto s = status(*watcher);
      if (!s) return std::string("observer lost");
      if (s->latched_fault == ErrorCode::kDeadman) return std::string{};
      if (s->state == ProcedureState::kAligned) {
        return std::string("the motion finished before the disconnect was noticed (sim too fast?)");
      }
      std::this_thread::sleep_for(Milliseconds{20});
    }
    return std::string("no DEADMAN latched");
  });
  clean("faults: Reset after DEADMAN");
}

// ---- garbage must not hurt other sessions ----
void Suite::garbage() {
  check("garbage: an observer keeps getting replies while other sessions send garbage", [&] {
    auto observer = greeted(Role::kObserver);
    if (!observer) return std::string("cannot connect");
    std::atomic<bool> done{false};
    std::atomic<int> answered{0}, unanswered{0};
    std::thread pinger([&] {
      while (!done.load()) {
        if (observer->request(protocol::Ping{1}).get<protocol::Pong>()) {
          ++answered;
        } else {
          ++unanswered;
        }
      }
    });
    std::mt19937 rng(12345);
    std::uniform_int_distribution<int> byte(0, 255);
    std::string why;
    for (int round = 0; round < 12 && why.empty(); ++round) {
      auto g = open();
      if (!g) {
        why = "a new connection was refused during garbage";
        break;
      }
      std::vector<std::uint8_t> junk(200 + static_cast<std::size_t>(round) * 50);
      for (auto& b : junk)
        b = static_cast<std::uint8_t>(byte(rng));
      switch (round % 4) {
        case 0:  // random bytes: bad magic, closed
          junk[0] = 'X';
          g->send_raw(junk);
          if (!g->wait_closed(timeout())) why = "random bytes did not close the connection";
          break;
        case 1: {  // a burst of CRC-damaged frames, then a good Ping on the same session
          (void)g->hello(Role::kObserver);
          for (int i = 0; i < 50; ++i) {
            auto f = frame_bytes(
                protocol::Envelope{static_cast<std::uint32_t>(100 + i), 0, protocol::Ping{}});
            f[f.size() - 1] ^= 0xFF;
            g->send_raw(f);
          }
          if (!still_usable(*g).empty()) why = "session unusable after CRC-damaged frames";
          break;
        }
        case 2: {  // a valid header announcing a huge payload
          auto f = frame_bytes(protocol::Envelope{7, 0, protocol::Ping{}});
          put_u32(f, protocol::kOffsetPayloadLength, 0xFFFFFFFFu);
          g->send_raw(f);
          if (!g->wait_closed(timeout())) why = "an oversize header did not close the connection";
          break;
        }
        case 3: {  // half a frame, then hang up
          auto f = frame_bytes(protocol::Envelope{7, 0, protocol::Ping{}});
          f.resize(f.size() / 2);
          g->send_raw(f);
          std::this_thread::sleep_for(Milliseconds{20});
          g->close();
          break;
        }
      }
    }
    std::this_thread::sleep_for(Milliseconds{50});
    done = true;
    pinger.join();
    if (!why.empty()) return why;
    if (unanswered.load() > 0) {
      return std::to_string(unanswered.load()) + " of the observer's Pings went unanswered";
    }
    if (answered.load() == 0) return std::string("the observer got no Pong at all");
    return still_usable(*observer);
  });
}

}  // namespace ajar::conformance
