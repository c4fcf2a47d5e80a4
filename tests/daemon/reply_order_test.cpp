// Randomized hostile orderings of the reply-before-events rule (docs/protocol.md 6.6 and 6.2): the
// real SessionHub over fake links, in front of the real engine over the deterministic mock card
// and the mock arm, on a fake clock with the loop run by hand (a seed replays exactly).
//
// The state store's saves land only when the seed says (the hub sees the engine's settled
// generation through a gate the test opens), so durable Acks are held for as long as the scenario
// wants; the black box answers when the seed says (a fake Recordings). Each seed is a random
// sequence of reads of several frames (the procedure's commands, Drive, Approach, Stop and
// EmergencyStop — also right behind a held Ack —, Reset, duplicates of held and answered requests,
// Ping, GetStatus, black-box requests), observers' reads (stops, refused commands), take-overs by
// a new controller session (also mid-motion, also with the loop's reports not yet taken),
// disconnects and reconnects, and loop cycles with and without the engine's poll.
//
// The model: every reply is placed where the hub handed its request to the engine (after the
// engine caught up: what happened before it goes first), every event the engine emits where it
// emits it — except while a request is handled, when it goes after that request's reply (for a
// Hello that takes control: after its Welcome and the control_changed naming it). Each session
// must receive exactly that sequence (Telemetry aside), with only a suffix missing, starting at a
// reply that may legitimately wait: a durable Ack whose save has not landed (the gate) or a black
// box that has not answered. Hence, for every seed and every session:
//   - every reply comes after the events of what happened before its request and before the
//     events its request causes; replies in request order, exactly one each;
//   - nothing overtakes a held reply: no later reply, no event (a Stop's Ack and the events of its
//     stop included) is delivered before it;
//   - nothing else is held: a Stop's or EmergencyStop's Ack, an observer's events, a reply on a
//     session with nothing held go out at once;
//   - a Stop or EmergencyStop behind a held Ack still reaches the engine at once, and one cycle
//     later the wheels are stopping (or an emergency stop reached the card);
//   - on a take-over: the new controller's Welcome, then control_changed, then the old
//     controller's stop, on every session.
//
//   AJAR_SEED=<n>   replay one seed (prints its trace)
//   AJAR_SEEDS=<n>  number of seeds (default 600, 120 under sanitizers)
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/logging.hpp"
#include "ajar/daemon/recordings.hpp"
#include "ajar/daemon/session_hub.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "ajar/protocol/codec.hpp"
#include "campaign_seeds.hpp"
#include "det_mock_card.hpp"
#include "fake_engine.hpp"
#include "fake_door.hpp"
#include "recording_link.hpp"

namespace ajar::testing::reply_order {
namespace {

using protocol::EventKind;
using protocol::MessageType;

constexpr std::int64_t kPeriodNs = 2'000'000;  // 500 Hz
constexpr std::uint64_t kCiSeeds = test::ci_size(600, 120);

// The black box answers when the test says.
class LateRecordings final : public daemon::Recordings {
 public:
  void handle(const protocol::Message&, Done done) override { pending.push_back(std::move(done)); }
  std::deque<Done> pending;
};

// What a session must receive, in order.
struct Item {
  char kind = 'R';               // 'R' a reply, 'E' an engine event, 'C' control_changed
  std::uint32_t request_id = 0;  // 'R'
  std::size_t event = 0;         // 'E': index into World::events_
  std::uint64_t generation = 0;  // 'R': a durable Ack's save generation (0: not durable)
  bool black_box = false;        // 'R': answered by the black box
  bool is_stop = false;          // 'R': the Ack of a Stop or EmergencyStop
};

class Link final : public RecordingLink {
 public:
  Link(std::uint64_t id, std::uint64_t client_instance)
      : RecordingLink(id, client_instance, 50000 + id) {}

  bool greeted = false;     // the model's view
  std::size_t checked = 0;  // frames already matched against `expected`
  std::size_t matched = 0;  // items of `expected` received
  std::vector<Item> expected;
};

class World {
 public:
  World(std::uint64_t seed, const std::string& dir, bool verbose)
      : seed_(seed), rng_(seed), verbose_(verbose) {
    config_ = test_config(dir);
    config_.state.directory = dir + "/state-" + std::to_string(seed % 4);
    config_.recorder.enabled = false;
    config_.safety.deadman_timeout_s = 0.05;
    config_.safety.arm_task_timeout_s = 1.0;
    config_.safety.arm_stop_timeout_s = 0.04;
    config_.control.motion_timeout_margin_s = 0.2;
    config_.drive.command_timeout_s = 0.1;
    fast_disk_ = seed % 4 == 0;  // saves land after every action on a quarter of the seeds
    left_ = config_.base.left.card_axis;
    right_ = config_.base.right.card_axis;
    auto card = make_det_card(clock_);
    card_ = card.get();
    drivers::DriverSet set;
    set.card = std::move(card);
    auto arm = std::make_unique<drivers::MockManipulator>(drivers::MockArmFault::kStuck, 40,
                                                          clock_.clock());
    arm_ = arm.get();
    set.arm = std::move(arm);
    daemon::EngineOptions options;
    options.now_ns = clock_.clock();
    options.manual_loop = true;
    std::filesystem::remove_all(config_.state.directory);
    engine_ = daemon::make_engine(config_, std::move(set), std::move(options));
    // The real engine as the hub sees it, with the save gate (the hub's settled generation is
    // the engine's, but never beyond what the test let land: land_saves()); calls the test must
    // place in its model are reported through the hooks.
    gated_ = test::FakeEngine::in_front_of(*engine_);
    gated_->gate_saves(0);
    gated_->before_command = [this](const protocol::Message& m) { on_command(m); };
    gated_->before_lost = [this] { lost_in_request_ = handling_ != nullptr; };
    gated_->after_command = [this](bool durable) {
      if (handling_ != nullptr && durable && !handling_->expected.empty()) {
        // The reply placed in before_command: durable (the hub holds it until this generation).
        for (auto it = handling_->expected.rbegin(); it != handling_->expected.rend(); ++it) {
          if (it->kind == 'R' && it->request_id == handling_rid_) {
            it->generation = engine_->accepted_generation();
            break;
          }
        }
      }
    };
    daemon::SessionHub::Options hub_options;
    hub_options.recordings = &recordings_;
    hub_ = std::make_unique<daemon::SessionHub>(*gated_, hub_options);
    engine_->set_event_sink([this](const protocol::Event& e) { on_event(e); });
    engine_->start();
    controller_ = connect(protocol::Role::kController, false, 0x2000 + seed);
    observer_ = connect(protocol::Role::kObserver, false, 0);
  }
  ~World() {
    engine_->set_event_sink([](const protocol::Event&) {});  // the hub goes first
    hub_.reset();
    engine_->shutdown();
  }

  std::string run(int steps) {
    for (int i = 0; i < steps && violation_.empty(); ++i)
      step();
    if (violation_.empty()) finish();
    return violation_;
  }
  const std::vector<std::string>& trace() const { return trace_; }
  const std::map<std::string, long>& coverage() const { return coverage_; }

 private:
  // ---- the model ----

  void on_event(const protocol::Event& e) {
    events_.push_back(e);
    const std::size_t index = events_.size() - 1;
    note("  event " + std::string(protocol::to_string(e.kind)) + " " +
         std::string(e.detail.view()));
    // While a request is handled: what the engine emits once it has the request (or, for a
    // take-over, once it heard of the old controller's loss) goes after the reply; what it
    // emitted catching up before that goes before.
    if (handling_ != nullptr && (reply_placed_ || lost_in_request_)) {
      caused_.push_back(index);
    } else {
      place_event(index);
    }
    hub_->on_event(e);
  }
  void place_event(std::size_t index) {
    for (auto& l : links_)
      if (l->greeted && !l->closed) l->expected.push_back(Item{'E', 0, index});
  }
  void place_reply(Link& link, std::uint32_t rid, bool is_stop) {
    if (reply_placed_) return;
    reply_placed_ = true;
    Item r{'R', rid};
    r.is_stop = is_stop;
    link.expected.push_back(r);
  }
  // The hub hands a request to the engine: its reply goes here (after what catch_up emitted).
  void on_command(const protocol::Message& m) {
    if (handling_ == nullptr) return fail("the engine got a command outside any request");
    const MessageType t = protocol::type_of(m);
    if (t == MessageType::kStop || t == MessageType::kEmergencyStop) stop_reached_engine_ = true;
    place_reply(*handling_, handling_rid_, false);
    if (t == MessageType::kStop || t == MessageType::kEmergencyStop)
      handling_->expected.back().is_stop = true;
  }

  // ---- sessions ----

  Link* connect(protocol::Role role, bool take_over, std::uint64_t instance) {
    links_.push_back(std::make_unique<Link>(next_link_++, instance));
    Link* link = links_.back().get();
    hub_->on_open(*link);
    protocol::Hello hello;
    hello.requested_role = role;
    hello.take_over = take_over;
    hello.client_instance_id = instance;
    hello.client_name = "order";
    read(*link, {protocol::Message{hello}});
    return link;
  }

  void disconnect(Link* link) {
    note("session " + std::to_string(link->id()) + " disconnects");
    link->closed = true;
    const bool was_controller = link == controller_;
    if (was_controller) controller_ = nullptr;
    if (link == observer_) observer_ = nullptr;
    // The controller's loss: its stop's events where emitted, then control_changed (no reply).
    hub_->on_closed(*link, "test");
    if (was_controller) {
      for (auto& l : links_)
        if (l->greeted && !l->closed) l->expected.push_back(Item{'C'});
    }
    for (auto it = links_.begin(); it != links_.end(); ++it) {
      if (it->get() == link) {
        links_.erase(it);
        break;
      }
    }
    check_all();
  }

  struct Frame {
    protocol::Message message;
    std::uint32_t repeat_of = 0;  // a duplicate of that request id
  };
  void read(Link& link, std::initializer_list<protocol::Message> messages) {
    std::vector<Frame> frames;
    for (const auto& m : messages)
      frames.push_back({m, 0});
    read(link, frames);
  }
  void read(Link& link, const std::vector<Frame>& frames) {
    bool stop_last = false;  // a stop with no wheel command after it in this read
    hub_->on_read_begin(link);
    for (const auto& f : frames) {
      if (!violation_.empty() || link.closed) break;
      const MessageType t = protocol::type_of(f.message);
      deliver(link, f);
      if (t == MessageType::kStop || t == MessageType::kEmergencyStop) {
        stop_last = true;
      } else if (t == MessageType::kAlignBase || t == MessageType::kApproach ||
                 t == MessageType::kDrive || t == MessageType::kReset ||
                 t == MessageType::kEngage || t == MessageType::kHello) {
        stop_last = false;
      }
    }
    hub_->on_read_end(link);  // a motion the read started: its events after every reply of it
    check_all();
    if (stop_last && violation_.empty()) {
      // The stop acts at once, whatever its Ack waits for: one period later nothing runs on.
      const std::size_t from = card_->log_size();
      const bool estop = std::any_of(frames.begin(), frames.end(), [](const Frame& f) {
        return protocol::type_of(f.message) == MessageType::kEmergencyStop;
      });
      cycle(false);
      if (estop && count_calls(*card_, CardCall::kEmergencyStop, from) == 0 &&
          !stopping_or_at_rest(*card_, {left_, right_})) {
        fail("an EmergencyStop did not reach the card within one period");
      }
      if (!stopping_or_at_rest(*card_, {left_, right_}))
        fail("a wheel runs on one period after a Stop (its Ack may still be held)");
    }
  }

  void deliver(Link& link, const Frame& f) {
    const MessageType t = protocol::type_of(f.message);
    const std::uint32_t rid = f.repeat_of != 0 ? f.repeat_of : next_request_++;
    std::ostringstream line;
    line << "session " << link.id() << (&link == controller_ ? " (controller)" : "") << ": "
         << (f.repeat_of != 0 ? "repeat " : "") << protocol::to_string(t) << " #" << rid;
    note(line.str());
    const bool held_before = link.matched < link.expected.size();
    if ((t == MessageType::kStop || t == MessageType::kEmergencyStop) && held_before)
      bump("stop behind a held reply");
    if (f.repeat_of != 0 && held_before) bump("repeat while replies are held");
    handling_ = &link;
    handling_rid_ = rid;
    reply_placed_ = false;
    lost_in_request_ = false;
    stop_reached_engine_ = false;
    const std::size_t bb_pending = recordings_.pending.size();
    caused_.clear();
    const bool hello = t == MessageType::kHello;
    const std::optional<std::uint64_t> controller_before = hub_->controller();
    if (hello && controller_before && controller_ != nullptr && card_moving()) {
      bump("take-over mid-motion");
    }
    const std::size_t placed_before = link.expected.size();
    hub_->on_message(link, protocol::Envelope{rid, 0, f.message});
    handling_ = nullptr;
    lost_in_request_ = false;
    if (recordings_.pending.size() > bb_pending) pending_rids_.push_back(rid);
    if ((t == MessageType::kStop || t == MessageType::kEmergencyStop) && !stop_reached_engine_) {
      return fail("a Stop/EmergencyStop did not reach the engine at once");
    }
    if (hello) {
      // The Welcome (or refusal), then control_changed if control changed hands, then the events
      // the Hello caused (the old controller's stop).
      place_reply(link, rid, false);
      const bool now_controller = hub_->controller() == link.id();
      const bool observer =
          std::get<protocol::Hello>(f.message).requested_role == protocol::Role::kObserver;
      if (now_controller || observer) link.greeted = true;
      if (now_controller && controller_before != link.id()) {
        for (auto& l : links_)
          if (l->greeted && !l->closed) l->expected.push_back(Item{'C'});
        if (controller_before) bump("take-over");
      }
    } else {
      place_reply(link, rid, false);  // not handed to the engine: placed when handled
    }
    if (recordings_.pending.size() > bb_pending) {  // the black box answers it later
      for (std::size_t i = placed_before; i < link.expected.size(); ++i)
        if (link.expected[i].kind == 'R' && link.expected[i].request_id == rid)
          link.expected[i].black_box = true;
    }
    if (f.repeat_of != 0) {  // a repeat may wait for the generation accepted when it came
      for (std::size_t i = placed_before; i < link.expected.size(); ++i)
        if (link.expected[i].kind == 'R' && link.expected[i].request_id == rid)
          link.expected[i].generation = engine_->accepted_generation();
    }
    for (const std::size_t e : caused_)
      place_event(e);
    if (!caused_.empty() && link.matched < placed_before)
      bump("events deferred behind a held reply");
    caused_.clear();
    sent_[rid] = f.message;
    last_rid_ = rid;
    last_rid_link_ = link.instance;
  }

  // The frames a link got so far against what it must get: a prefix, and what is missing starts
  // at a reply that may wait.
  void check(Link& link) {
    while (link.checked < link.frames.size()) {
      const auto out = protocol::decode_frame(*link.frames[link.checked]);
      ++link.checked;
      if (out.kind != protocol::StreamDecoder::Kind::kMessage)
        return fail("session " + std::to_string(link.id()) + ": a frame that does not decode");
      const auto& env = out.envelope;
      if (std::holds_alternative<protocol::Telemetry>(env.message)) continue;
      if (link.matched >= link.expected.size())
        return fail("session " + std::to_string(link.id()) + ": a frame nobody expected (" +
                    std::string(protocol::to_string(protocol::type_of(env.message))) + ")");
      const Item& want = link.expected[link.matched];
      std::ostringstream why;
      why << "session " << link.id() << ", item " << link.matched << ": expected ";
      if (want.kind == 'R') {
        why << "the reply to request " << want.request_id;
      } else if (want.kind == 'C') {
        why << "control_changed";
      } else {
        why << "event " << protocol::to_string(events_[want.event].kind) << " ("
            << events_[want.event].detail.view() << ")";
      }
      why << ", got ";
      if (env.request_id != 0) {
        why << "the reply to request " << env.request_id;
      } else if (const auto* e = std::get_if<protocol::Event>(&env.message)) {
        why << "event " << protocol::to_string(e->kind) << " (" << e->detail.view() << ")";
      } else {
        why << protocol::to_string(protocol::type_of(env.message));
      }
      bool ok = false;
      if (want.kind == 'R') {
        ok = env.request_id == want.request_id;
      } else if (const auto* e = std::get_if<protocol::Event>(&env.message);
                 e != nullptr && env.request_id == 0) {
        ok = want.kind == 'C' ? e->kind == EventKind::kControlChanged
                              : protocol::wire_equal(protocol::Message{*e},
                                                     protocol::Message{events_[want.event]});
      }
      if (!ok) return fail(why.str());
      ++link.matched;
    }
    if (link.matched == link.expected.size()) return;
    // Only a reply that may wait heads what is missing: a durable Ack whose save has not landed
    // (as the hub last saw it), or the black box's answer not given yet.
    const Item& first = link.expected[link.matched];
    const bool may_wait = first.kind == 'R' &&
                          ((first.generation != 0 && first.generation > gated_->settled_seen()) ||
                           (first.black_box && std::find(pending_rids_.begin(), pending_rids_.end(),
                                                         first.request_id) != pending_rids_.end()));
    if (!may_wait) {
      std::ostringstream why;
      why << "session " << link.id() << ": item " << link.matched << " held without reason ("
          << (first.kind == 'R'   ? (first.is_stop ? "a stop's Ack" : "a reply")
              : first.kind == 'C' ? "control_changed"
                                  : "an event")
          << (first.kind == 'R' ? " to request " + std::to_string(first.request_id) : "")
          << ", generation " << first.generation << ", settled " << gated_->settled_seen() << ")";
      return fail(why.str());
    }
    bump(first.black_box ? "reply held for the black box" : "durable ack held");
  }
  void check_all() {
    for (auto& l : links_)
      if (!l->closed && violation_.empty()) check(*l);
  }

  // ---- the scenario ----

  int pick(int n) { return static_cast<int>(rng_() % static_cast<std::uint64_t>(n)); }

  protocol::Message procedure_step() {
    const auto s = engine_->status();
    if (!s.has_width || pick(8) == 0) return good_width();
    if (!s.has_handle || pick(8) == 0) return good_handle();
    if (!s.has_plane || pick(6) == 0)
      return plane_at_yaw((pick(2) == 0 ? -1 : 1) * (0.02 + 0.01 * pick(10)));
    if (s.state == protocol::ProcedureState::kReadyToAlign) return protocol::AlignBase{};
    if (!s.has_contact) return good_contact();
    return protocol::Engage{};
  }
  Frame random_command() {
    const int what = pick(100);
    if (what < 8 && last_rid_ != 0 && controller_ != nullptr &&
        last_rid_link_ == controller_->instance) {
      return {sent_[last_rid_], last_rid_};
    }
    if (what < 35) return {procedure_step()};
    if (what < 47) return {protocol::Stop{}};
    if (what < 51) return {protocol::EmergencyStop{}};
    if (what < 58) return {protocol::Reset{pick(5) == 0}};
    if (what < 70) {
      const double v[] = {0, 0.05, 0.1, -0.05};
      return {protocol::Drive{v[pick(4)], pick(3) == 0 ? 0.2 : 0.0}};
    }
    if (what < 76) return {protocol::Approach{0.8 + 0.1 * pick(5)}};
    if (what < 80) return {protocol::AlignBase{}};
    if (what < 86) return {protocol::Ping{1}};
    if (what < 91) return {protocol::GetStatus{}};
    if (what < 95) return {protocol::ListRecordings{0}};
    return {plane_at_yaw(0.05)};
  }

  void step() {
    const int what = pick(100);
    if (what < 50) {
      if (controller_ == nullptr) {
        controller_ = connect(protocol::Role::kController, pick(2) == 0, 0x2000 + seed_);
      } else {
        std::vector<Frame> frames;
        const int n = 1 + pick(5);
        for (int i = 0; i < n; ++i)
          frames.push_back(random_command());
        // A measurement (a durable Ack) right before a Stop, in one read: the reported case.
        if (pick(5) == 0) frames = {{good_width()}, {protocol::Stop{}}};
        read(*controller_, frames);
      }
    } else if (what < 58) {
      if (observer_ == nullptr) {
        observer_ = connect(protocol::Role::kObserver, false, 0);
      } else {
        const protocol::Message m[] = {protocol::Stop{}, protocol::GetStatus{},
                                       protocol::AlignBase{}, protocol::EmergencyStop{},
                                       protocol::Ping{2}};
        read(*observer_, {m[pick(5)]});
      }
    } else if (what < 64) {
      // Take-over by a new controller session (the same client instance on some: its
      // duplicates carry over), sometimes with commands in the same read.
      Link* old = controller_;
      const std::uint64_t instance = pick(2) == 0 ? 0x2000 + seed_ : 0x3000 + next_link_;
      links_.push_back(std::make_unique<Link>(next_link_++, instance));
      Link* link = links_.back().get();
      hub_->on_open(*link);
      protocol::Hello hello;
      hello.requested_role = protocol::Role::kController;
      hello.take_over = true;
      hello.client_instance_id = instance;
      std::vector<Frame> frames{{hello}};
      if (pick(2) == 0) frames.push_back(random_command());
      controller_ = link;
      read(*link, frames);
      if (old != nullptr && pick(2) == 0) disconnect(old);
    } else if (what < 68) {
      if (controller_ != nullptr) disconnect(controller_);
    } else if (what < 73) {
      if (!recordings_.pending.empty()) answer_black_box();
    } else if (what < 80) {
      land_saves();
    } else if (what < 84) {
      arm_->set_phase(pick(2) == 0 ? drivers::ArmPhase::kDone : drivers::ArmPhase::kIdle);
    } else if (what < 86) {
      // A controller silent for a while (the deadman).
      for (int i = 0; i < 40 && violation_.empty(); ++i)
        cycle(pick(2) == 0, false);
    }
    const int cycles = 1 + pick(what >= 90 ? 60 : 6);
    for (int i = 0; i < cycles && violation_.empty(); ++i)
      cycle(pick(3) != 0);  // without the engine's poll on some: reports wait for catch_up
    if (fast_disk_) land_saves();
  }

  // The black box answers its oldest request.
  void answer_black_box() {
    auto done = std::move(recordings_.pending.front());
    recordings_.pending.pop_front();
    note("black box answers request " + std::to_string(pending_rids_.front()));
    pending_rids_.pop_front();
    done(protocol::RecordingList{});
    check_all();
  }

  // The disk lands every save submitted so far (the gate opens up to it once the writer is done).
  void land_saves() {
    const std::uint64_t accepted = engine_->accepted_generation();
    for (int i = 0; i < 20000 && engine_->settled_generation() < accepted; ++i)
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    if (engine_->settled_generation() < accepted) return fail("the state store did not settle");
    gated_->gate_saves(accepted);
    tick();
  }

  void tick() {
    hub_->tick(daemon::SessionHub::Clock::now());
    check_all();
  }

  bool card_moving() { return card_->peek(left_).moving || card_->peek(right_).moving; }

  void cycle(bool poll, bool heartbeat = true) {
    clock_.advance_ns(kPeriodNs);
    ++cycles_;
    if (heartbeat && controller_ != nullptr && cycles_ % 5 == 0) {
      read(*controller_, {protocol::Message{protocol::Ping{3}}});
    }
    engine_->run_loop_cycle();
    if (poll) engine_->poll();
    tick();
  }

  // The end: every save lands, the black box answers, the loop settles: everything held arrives.
  void finish() {
    while (!recordings_.pending.empty() && violation_.empty())
      answer_black_box();
    // The wheels come to rest (a Stop through the model like any other), so that the engine's
    // shutdown does not wait for them on a clock that no longer runs.
    Link* stopper = controller_ != nullptr ? controller_ : observer_;
    if (stopper != nullptr && card_moving()) read(*stopper, {protocol::Message{protocol::Stop{}}});
    for (int i = 0; i < 500 && violation_.empty() && (i < 50 || card_moving()); ++i)
      cycle(true);
    land_saves();
    for (auto& l : links_) {
      if (l->closed || !violation_.empty()) continue;
      check(*l);
      if (l->matched != l->expected.size())
        fail("session " + std::to_string(l->id()) + ": " +
             std::to_string(l->expected.size() - l->matched) +
             " item(s) never arrived after every save landed");
    }
  }

  void bump(const std::string& what) { ++coverage_[what]; }
  void note(const std::string& line) {
    trace_.push_back(line);
    if (verbose_) std::cout << line << "\n";
  }
  void fail(const std::string& what) {
    if (violation_.empty()) violation_ = what;
  }

  std::uint64_t seed_;
  std::mt19937_64 rng_;
  bool verbose_;
  bool fast_disk_ = false;
  daemon::Config config_;
  FakeClock clock_;
  std::uint64_t cycles_ = 0;
  drivers::MockMotionCard* card_ = nullptr;
  drivers::MockManipulator* arm_ = nullptr;
  int left_ = 1, right_ = 2;
  std::unique_ptr<daemon::Engine> engine_;
  std::unique_ptr<test::FakeEngine> gated_;
  LateRecordings recordings_;
  std::unique_ptr<daemon::SessionHub> hub_;
  std::vector<std::unique_ptr<Link>> links_;
  std::uint64_t next_link_ = 1;
  std::uint32_t next_request_ = 1;
  Link* controller_ = nullptr;
  Link* observer_ = nullptr;
  Link* handling_ = nullptr;  // the session whose request the hub is handling
  std::uint32_t handling_rid_ = 0;
  bool reply_placed_ = false;
  bool stop_reached_engine_ = false;
  std::vector<std::size_t> caused_;  // events emitted while the request is handled
  std::vector<protocol::Event> events_;
  std::map<std::uint32_t, protocol::Message> sent_;
  std::uint32_t last_rid_ = 0;
  std::uint64_t last_rid_link_ = 0;
  bool lost_in_request_ = false;  // the request being handled took control (controller_lost)
  std::deque<std::uint32_t> pending_rids_;  // the black box's requests not answered, in order
  std::map<std::string, long> coverage_;
  std::vector<std::string> trace_;
  std::string violation_;
};

TEST(ReplyOrder, RandomHostileOrderingsKeepEveryReplyBeforeTheEventsItCauses) {
  daemon::set_log_level(daemon::LogLevel::kNone);
  std::string pattern =
      std::filesystem::exists("/dev/shm") ? "/dev/shm/ajar-order-XXXXXX" : "/tmp/ajar-order-XXXXXX";
  const std::string dir = ::mkdtemp(pattern.data()) != nullptr ? pattern : std::string("/tmp");
  const auto [first, count, replay] = test::seed_range(kCiSeeds);
  std::cout << "seeds " << first << ".." << first + count - 1
            << " (replay one with AJAR_SEED=<n>)\n";
  int failures = 0;
  std::map<std::string, long> total;
  for (std::uint64_t seed = first; seed < first + count && failures < 3; ++seed) {
    World world(seed, dir, replay);
    const std::string violation = world.run(80);
    for (const auto& [k, v] : world.coverage())
      total[k] += v;
    if (!violation.empty()) {
      ++failures;
      std::ostringstream out;
      const auto& t = world.trace();
      for (std::size_t i = t.size() > 40 ? t.size() - 40 : 0; i < t.size(); ++i)
        out << "  " << t[i] << "\n";
      ADD_FAILURE() << "seed " << seed << ": " << violation << "\n"
                    << out.str() << "replay with AJAR_SEED=" << seed;
    }
  }
  daemon::set_log_level(daemon::LogLevel::kInfo);
  std::filesystem::remove_all(dir);
  std::cout << "coverage over " << count << " seeds:\n";
  for (const auto& [k, v] : total)
    std::cout << "  " << k << ": " << v << "\n";
  if (replay || count < kCiSeeds) return;
  for (const char* what : {"stop behind a held reply", "events deferred behind a held reply",
                           "durable ack held", "reply held for the black box", "take-over",
                           "take-over mid-motion", "repeat while replies are held"}) {
    EXPECT_GE(total[what], 10) << "the campaign no longer reaches: " << what;
  }
}

// The engine on `clock`, its loop run by hand (run_loop_cycle), over the deterministic card and
// an arm that never finishes its task.
std::unique_ptr<daemon::Engine> engine_with_stuck_arm(const daemon::Config& config,
                                                      FakeClock& clock) {
  drivers::DriverSet set;
  set.card = make_det_card(clock);
  set.arm =
      std::make_unique<drivers::MockManipulator>(drivers::MockArmFault::kStuck, 40, clock.clock());
  daemon::EngineOptions options;
  options.now_ns = clock.clock();
  options.manual_loop = true;
  return daemon::make_engine(config, std::move(set), std::move(options));
}

// What `l` received from its frame `from` on: each message's type, an event's kind instead.
std::vector<std::string> frame_kinds(const Link& l, std::size_t from) {
  std::vector<std::string> out;
  for (std::size_t i = from; i < l.frames.size(); ++i) {
    const auto d = protocol::decode_frame(*l.frames[i]);
    if (const auto* e = std::get_if<protocol::Event>(&d.envelope.message)) {
      out.push_back(std::string(protocol::to_string(e->kind)));
    } else {
      out.push_back(std::string(protocol::to_string(protocol::type_of(d.envelope.message))));
    }
  }
  return out;
}

// A take-over while the loop's report of a finished motion has not been taken yet (the I/O thread
// polls the engine every few ms; the loop reports at once): that motion finished before the
// Hello, so its events go out before the control_changed, and the new controller — not greeted
// when it happened — does not get them after its Welcome as if the take-over had caused them.
TEST(ReplyOrder, ATakeOverCatchesUpBeforeItsWelcome) {
  daemon::set_log_level(daemon::LogLevel::kNone);
  TempDir dir;
  auto config = test_config(dir.path());
  config.recorder.enabled = false;
  FakeClock clock;
  auto engine = engine_with_stuck_arm(config, clock);
  daemon::SessionHub hub(*engine);
  engine->set_event_sink([&hub](const protocol::Event& e) { hub.on_event(e); });
  engine->start();
  Link a(1, 0xA), o(2, 0), b(3, 0xB);
  std::uint32_t rid = 1;
  const auto send = [&](Link& link, const protocol::Message& m) {
    hub.on_read_begin(link);
    hub.on_message(link, protocol::Envelope{rid++, 0, m});
    hub.on_read_end(link);
  };
  const auto settle = [&] {
    for (int i = 0; i < 20000 && engine->settled_generation() < engine->accepted_generation(); ++i)
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    hub.tick(daemon::SessionHub::Clock::now());
  };
  for (Link* l : {&a, &o, &b})
    hub.on_open(*l);
  protocol::Hello hello;
  hello.requested_role = protocol::Role::kController;
  hello.client_instance_id = a.instance;
  send(a, hello);
  hello.requested_role = protocol::Role::kObserver;
  hello.client_instance_id = 0;
  send(o, hello);
  for (const protocol::Message& m :
       {protocol::Message{good_width()}, protocol::Message{good_handle()},
        protocol::Message{plane_at_yaw(0.1)}, protocol::Message{protocol::AlignBase{}}}) {
    send(a, m);
    settle();
  }
  // The alignment runs to its end; the loop's report of it waits for the engine's next poll.
  for (int i = 0; i < 1500; ++i) {
    clock.advance_ns(kPeriodNs);
    engine->controller_heartbeat();
    engine->run_loop_cycle();
    if (i < 3) engine->poll();  // motion_started out
  }
  const std::size_t o_before = o.frames.size();
  hello.requested_role = protocol::Role::kController;
  hello.take_over = true;
  hello.client_instance_id = b.instance;
  send(b, hello);
  settle();
  const auto seen_by_o = frame_kinds(o, o_before);
  const auto finished = std::find(seen_by_o.begin(), seen_by_o.end(), "motion_finished");
  const auto changed = std::find(seen_by_o.begin(), seen_by_o.end(), "control_changed");
  ASSERT_NE(finished, seen_by_o.end()) << "the alignment did not finish";
  ASSERT_NE(changed, seen_by_o.end());
  EXPECT_LT(finished, changed)
      << "the observer was told the alignment finished after the take-over";
  const auto seen_by_b = frame_kinds(b, 0);
  ASSERT_FALSE(seen_by_b.empty());
  EXPECT_EQ(seen_by_b.front(), "Welcome");
  EXPECT_EQ(std::count(seen_by_b.begin(), seen_by_b.end(), "motion_finished"), 0)
      << "the new controller was told of a motion that finished before its Hello";
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk)
      << "a take-over after the motion finished latched a fault";
  engine->shutdown();
  daemon::set_log_level(daemon::LogLevel::kInfo);
}

}  // namespace
}  // namespace ajar::testing::reply_order
