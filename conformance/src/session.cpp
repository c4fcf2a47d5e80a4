// Session rules: Hello first, roles and take-over, telemetry.
#include "suite.hpp"

#include <condition_variable>

namespace ajar::conformance {

// ---- session rules ----
void Suite::session_rules() {
  check("session: requests before Hello get HELLO_REQUIRED; the session stays open", [&] {
    auto c = open();
    if (!c) return std::string("cannot connect");
    if (auto e = want_error(c->request(protocol::Ping{}), ErrorCode::kHelloRequired); !e.empty()) {
      return "Ping: " + e;
    }
    if (auto e = want_error(c->request(protocol::GetStatus{}), ErrorCode::kHelloRequired);
        !e.empty()) {
      return "GetStatus: " + e;
    }
    if (auto e = want_error(c->request(protocol::MeasureDoorWidth{}), ErrorCode::kHelloRequired);
        !e.empty()) {
      return "MeasureDoorWidth: " + e;
    }
    const Response w = c->hello(Role::kObserver);
    if (!w.get<protocol::Welcome>()) return "Hello after refusals: " + describe(w);
    return still_usable(*c);
  });
  check("session: Stop is accepted before Hello (safety)", [&] {
    auto c = open();
    if (!c) return std::string("cannot connect");
    return want<protocol::Ack>(c->request(protocol::Stop{}));
  });
  check("session: a second Hello gets ALREADY_GREETED", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    if (auto e = want_error(c->hello(Role::kObserver), ErrorCode::kAlreadyGreeted); !e.empty()) {
      return e;
    }
    return still_usable(*c);
  });
  check("session: Hello with version_major 2 gets UNSUPPORTED_VERSION", [&] {
    auto c = open();
    if (!c) return std::string("cannot connect");
    protocol::Hello hello;
    hello.version_major = 2;
    return want_error(c->request(hello), ErrorCode::kUnsupportedVersion, "version_major");
  });
  check("session: Welcome carries the granted role, limits and distinct session ids", [&] {
    auto a = open();
    auto b = open();
    if (!a || !b) return std::string("cannot connect");
    const Response ra = a->hello(Role::kObserver);
    const Response rb = b->hello(Role::kObserver);
    const auto* wa = ra.get<protocol::Welcome>();
    const auto* wb = rb.get<protocol::Welcome>();
    if (!wa || !wb) return std::string("no Welcome");
    if (wa->granted_role != Role::kObserver) return std::string("role not observer");
    if (wa->session_id == wb->session_id) return std::string("same session id twice");
    if (wa->version_major != protocol::kVersionMajor) return std::string("wrong major version");
    if (!(wa->min_door_width_m > 0 && wa->max_door_width_m > wa->min_door_width_m)) {
      return std::string("door width limits not sensible");
    }
    if (!(wa->deadman_timeout_s > 0)) return std::string("no deadman timeout");
    return std::string{};
  });
  check("session: Ping echoes client_time_ns with the request id", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    return still_usable(*c);
  });
}

void Suite::roles() {
  check("roles: observer commands get NOT_CONTROLLER; reads and Stop are allowed", [&] {
    auto ctl = greeted(Role::kController, true);
    auto obs = greeted(Role::kObserver);
    if (!ctl || !obs) return std::string("cannot connect");
    for (const protocol::Message& m :
         {protocol::Message{
              protocol::MeasureDoorWidth{base_point(1, 0.4, 0), base_point(1, -0.4, 0)}},
          protocol::Message{protocol::MeasureHandle{}}, protocol::Message{door_plane(0.1)},
          protocol::Message{protocol::SetContactPoint{}}, protocol::Message{protocol::AlignBase{}},
          protocol::Message{protocol::Engage{}}, protocol::Message{protocol::Reset{true}}}) {
      if (auto e = want_error(obs->request(m), ErrorCode::kNotController); !e.empty()) {
        return std::string(protocol::to_string(protocol::type_of(m))) + ": " + e;
      }
    }
    if (auto e = want<protocol::Status>(obs->request(protocol::GetStatus{})); !e.empty()) return e;
    if (auto e = want<protocol::Ack>(obs->request(protocol::Stop{})); !e.empty()) return e;
    return still_usable(*obs);
  });
  check("roles: a second controller without take_over gets CONTROLLER_BUSY, may then observe", [&] {
    auto ctl = greeted(Role::kController, true);
    auto other = open();
    if (!ctl || !other) return std::string("cannot connect");
    if (auto e = want_error(other->hello(Role::kController, false), ErrorCode::kControllerBusy,
                            "take_over");
        !e.empty()) {
      return e;
    }
    const Response w = other->hello(Role::kObserver);
    if (!w.get<protocol::Welcome>()) return "Hello as observer after: " + describe(w);
    return std::string{};
  });
  check("roles: take_over demotes the old controller and announces control_changed", [&] {
    // Declared before the client: its callback may run until the client is destroyed.
    std::mutex m;
    std::condition_variable cv;
    bool seen = false;
    auto old_ctl = greeted(Role::kController, true);
    if (!old_ctl) return std::string("cannot connect");
    old_ctl->on_event([&](const protocol::Event& e) {
      if (e.kind == protocol::EventKind::kControlChanged) {
        std::lock_guard lock(m);
        seen = true;
        cv.notify_all();
      }
    });
    auto new_ctl = greeted(Role::kController, true);
    if (!new_ctl) return std::string("take-over refused");
    if (auto e = want_error(old_ctl->request(protocol::Reset{false}), ErrorCode::kNotController);
        !e.empty()) {
      return "old controller: " + e;
    }
    if (auto e = want<protocol::Ack>(new_ctl->request(protocol::Reset{false})); !e.empty()) {
      return "new controller: " + e;
    }
    std::unique_lock lock(m);
    const bool ok = cv.wait_for(lock, timeout(), [&] { return seen; });
    lock.unlock();
    old_ctl->on_event(nullptr);
    return ok ? std::string{} : std::string("no control_changed event");
  });
  check("roles: the controller leaving frees control", [&] {
    {
      auto ctl = greeted(Role::kController, true);
      if (!ctl) return std::string("cannot connect");
    }
    for (int i = 0; i < 500; ++i) {  // up to ~10 s for the daemon to notice
      auto c = open();
      if (!c) return std::string("cannot connect");
      const Response r = c->hello(Role::kController, false);
      if (r.ok()) return std::string{};
      std::this_thread::sleep_for(Milliseconds{20});
    }
    return std::string("control still held after the controller disconnected");
  });
}

void Suite::telemetry() {
  check("telemetry: Subscribe delivers Telemetry; negative rate gets RATE_LIMITED", [&] {
    std::atomic<int> count{0};  // before the client: its callback may run until it is gone
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    if (auto e = want_error(c->request(protocol::Subscribe{-1.0f}), ErrorCode::kRateLimited,
                            "telemetry_rate_hz");
        !e.empty()) {
      return e;
    }
    c->on_telemetry([&](const protocol::Telemetry&) { ++count; });
    if (auto e = want<protocol::Ack>(c->request(protocol::Subscribe{100.0f})); !e.empty()) return e;
    const auto deadline = Clock::now() + timeout();
    while (count.load() < 3 && Clock::now() < deadline)
      std::this_thread::sleep_for(Milliseconds{10});
    if (count.load() < 3) return std::string("fewer than 3 Telemetry frames");
    if (auto e = want<protocol::Ack>(c->request(protocol::Subscribe{0.0f})); !e.empty()) return e;
    c->on_telemetry(nullptr);
    return std::string{};
  });
}

}  // namespace ajar::conformance
