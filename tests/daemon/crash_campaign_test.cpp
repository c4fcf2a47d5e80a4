// Crash and shutdown at any instant (issue 22): the real ajard (mock drivers) on one state
// directory, random sessions — measurements, alignments, jogs, Stop, EmergencyStop, Reset — and at
// a random point of each round SIGKILL or SIGTERM: at any instant, right after an EmergencyStop's
// Ack, with the disk hung under that Ack, with a measurement in flight, and during the SIGTERM
// shutdown another EmergencyStop or Stop. Then a restart on the same directory, which must show:
//   - a fault latched before is latched after: after a clean shutdown (exit 0) the same one; after
//     a kill that one or UNCLEAN_SHUTDOWN, and after a kill always some fault (no un-latched
//     start after an unclean end); no fault after a clean shutdown that had none;
//   - nothing moves (telemetry: not moving, nothing commanded, wheel counts still) and a Drive is
//     refused with FAULT_LATCHED until a Reset; a fault may also be carried, un-reset, into the
//     next round and must survive that one too;
//   - no durably acknowledged measurement is lost: the stored width and handle lengths and the
//     plane are those of the last Acks (for a request in flight at the kill: either outcome).
// Seeded: the seed is printed; AJAR_SEED=<n> replays its choices (the daemon's timing is not
// replayed); AJAR_CRASH_ROUNDS=<n> rounds (default 40; under sanitizers 12).
// No timing is asserted: every wait is bounded and checks an outcome.
#include <signal.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "ajard_restarts.hpp"
#include "campaign_seeds.hpp"
#include "e2e_fixture.hpp"

namespace ajar::test {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;
using protocol::Role;

constexpr std::uint64_t kCiRounds = ci_size(40, 12);

// What the state file must give back: the measurements the Acks accepted.
struct Stored {
  std::optional<double> width_m;
  std::optional<double> handle_m;
  bool plane = false;

  static bool same(const std::optional<double>& a, const std::optional<double>& b) {
    return a.has_value() == b.has_value() && (!a || std::abs(*a - *b) < 1e-5);
  }
  bool matches(const Stored& o) const {
    return same(width_m, o.width_m) && same(handle_m, o.handle_m) && plane == o.plane;
  }
  std::string text() const {
    std::ostringstream s;
    s << "width " << (width_m ? std::to_string(*width_m) : "-") << ", handle "
      << (handle_m ? std::to_string(*handle_m) : "-") << ", plane " << (plane ? "yes" : "no");
    return s.str();
  }
  static Stored of(const protocol::Status& s) {
    Stored r;
    if (s.has_width) r.width_m = s.width.length_m;
    if (s.has_handle) r.handle_m = s.handle.length_m;
    r.plane = s.has_plane;
    return r;
  }
};

enum class Ending : std::uint8_t {
  kKill,               // SIGKILL at once (the motion may be running)
  kKillAfterEstopAck,  // EmergencyStop, its Ack read, SIGKILL at once
  kKillOnHungDisk,     // the disk hangs, EmergencyStop, its Ack, SIGKILL
  kKillInFlight,       // a MeasureDoorWidth sent, no reply read, SIGKILL 0-3 ms later
  kTerm,               // SIGTERM, drained until the sessions close
  kTermThenEstop,      // SIGTERM, then an observer's EmergencyStop during the shutdown
  kTermThenStop,       // SIGTERM, then the controller's Stop during the shutdown
  kCount
};
constexpr const char* kEndingNames[] = {
    "kill", "kill-after-estop-ack", "kill-on-hung-disk", "kill-in-flight",
    "term", "term-then-estop",      "term-then-stop"};

class Campaign {
 public:
  Campaign(std::uint64_t seed, const std::string& dir, std::ostream& trace)
      : rng_(seed), dir_(dir), trace_(trace) {
    auto c = e2e_config(drivers::DriverKind::kMock, dir, 20.0);
    config_ = dir + "/ajard.yaml";
    state_dir_ = c.state.directory;
    std::ofstream(config_) << daemon::to_yaml(c);
  }

  // One round: start (checking what the last one left), a random session, an ending.
  void round(std::uint64_t n) {
    trace_ << "round " << n << ":";
    std::unique_ptr<AjardProcess> ajard;
    const auto port = start_ajard(ajard, config_, dir_, "round" + std::to_string(n % 4));
    ASSERT_TRUE(port) << ajard->err();
    TestClient observer(*port);
    observer.hello(Role::kObserver);
    check_restart(observer, n == 0);
    if (::testing::Test::HasFailure()) return;
    TestClient controller(*port);
    controller.hello(Role::kController, 0x1000 + n, true);
    if (fault_ != ErrorCode::kOk) {
      trace_ << " drive-refused";
      EXPECT_EQ(error_code_of(controller.request(protocol::Drive{0.1, 0.0})),
                ErrorCode::kFaultLatched);
      observer.request_as<protocol::Ack>(protocol::Subscribe{100});
      EXPECT_TRUE(nothing_moves(observer, 8)) << "a Drive before the Reset moved the base";
      observer.request_as<protocol::Ack>(protocol::Subscribe{0});
      if (chance(0.8)) act(controller, 8);  // the Reset (else the fault goes into the next round)
    }
    const int steps = uniform(1, 9);
    for (int i = 0; i < steps && !::testing::Test::HasFailure(); ++i)
      act(controller, uniform(0, 10));
    end(*ajard, controller, observer);
    trace_ << "\n";
  }

  std::map<std::string, int> counters;

 private:
  bool chance(double p) { return std::uniform_real_distribution<double>(0, 1)(rng_) < p; }
  int uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  double real(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }

  protocol::MeasureDoorWidth random_width(double& length) {
    length = real(0.7, 1.3);
    const double y1 = real(0.2, length - 0.2);
    return {ajar::testing::base_point(1.5, y1, 1.0),
            ajar::testing::base_point(1.5, y1 - length, 1.0)};
  }

  // After the restart: the fault and the measurements as the last round left them; nothing moves.
  void check_restart(TestClient& observer, bool first) {
    const auto status = observer.request_as<protocol::Status>(protocol::GetStatus{});
    const Stored stored = Stored::of(status);
    trace_ << " start(" << to_string(status.latched_fault) << "; " << stored.text() << ")";
    if (first) {
      EXPECT_EQ(status.latched_fault, ErrorCode::kOk) << "a first start latched a fault";
    } else if (killed_) {
      EXPECT_NE(status.latched_fault, ErrorCode::kOk) << "a start after a kill latched nothing";
      if (fault_ != ErrorCode::kOk && fault_ != ErrorCode::kInternal) {
        EXPECT_TRUE(status.latched_fault == fault_ ||
                    status.latched_fault == ErrorCode::kUncleanShutdown)
            << to_string(fault_) << " was latched before the kill, "
            << to_string(status.latched_fault) << " after";
      }
    } else if (fault_ == ErrorCode::kOk) {
      EXPECT_EQ(status.latched_fault, ErrorCode::kOk) << "a clean shutdown came back latched";
    } else {
      EXPECT_NE(status.latched_fault, ErrorCode::kOk)
          << to_string(fault_) << " was latched before the clean shutdown, nothing after";
      if (fault_ != ErrorCode::kInternal) {
        EXPECT_EQ(status.latched_fault, fault_);
      }
    }
    if (!first && killed_) {
      ++counters[status.latched_fault == ErrorCode::kUncleanShutdown
                     ? "after a kill: UNCLEAN_SHUTDOWN latched"
                     : "after a kill: the fault from before it restored"];
    } else if (!first && status.latched_fault != ErrorCode::kOk) {
      ++counters["after a clean shutdown: the fault from before it restored"];
    }
    if (allowed_.size() > 1) {
      ++counters[allowed_.back().matches(stored) && !allowed_.front().matches(stored)
                     ? "measurement in flight at the kill: found executed"
                     : "measurement in flight at the kill: not executed"];
    }
    bool found = false;
    for (const auto& s : allowed_)
      found = found || s.matches(stored);
    std::string expected;
    for (const auto& s : allowed_)
      expected += " [" + s.text() + "]";
    EXPECT_TRUE(found) << "stored " << stored.text() << "; expected one of" << expected;
    if (!first) {
      EXPECT_TRUE(status.restored_from_disk);
    }
    observer.request_as<protocol::Ack>(protocol::Subscribe{100});
    EXPECT_TRUE(nothing_moves(observer, 10)) << "something moved after the restart";
    observer.request_as<protocol::Ack>(protocol::Subscribe{0});
    fault_ = status.latched_fault;
    stored_ = stored;
    allowed_ = {stored_};
    killed_ = false;
    if (fault_ != ErrorCode::kOk) ++counters["restarts with a fault latched"];
  }

  // What the controller learns from the events before a reply and from the reply.
  void learn(TestClient& client, const protocol::Message& reply) {
    if (const auto* e = std::get_if<protocol::ErrorReply>(&reply)) {
      trace_ << "(" << to_string(e->code) << ")";
    }
    for (const auto& e : client.events()) {
      if (e.kind == EventKind::kFaultLatched && fault_ == ErrorCode::kOk) fault_ = e.fault;
      if (e.kind == EventKind::kFaultLatched && fault_ == ErrorCode::kInternal) fault_ = e.fault;
    }
    client.events().clear();
    if (const auto* ack = std::get_if<protocol::Ack>(&reply)) {
      // kInternal: latched, its code not known yet (the fault_latched event tells).
      if (ack->state == ProcedureState::kFault && fault_ == ErrorCode::kOk)
        fault_ = ErrorCode::kInternal;
    }
    if (const auto* status = std::get_if<protocol::Status>(&reply)) fault_ = status->latched_fault;
  }

  void act(TestClient& controller, int what) {
    static constexpr const char* kNames[] = {"width", "width", "handle", "plane", "align",
                                             "drive", "stop",  "estop",  "reset", "status"};
    trace_ << " " << (what >= 0 && what <= 9 ? kNames[what] : "wait");
    switch (what) {
      case 0:
      case 1: {
        double length = 0;
        const auto reply = controller.request(random_width(length));
        learn(controller, reply);
        if (const auto* ack = std::get_if<protocol::Ack>(&reply)) {
          stored_.width_m = std::get<protocol::SpanAck>(ack->body).length_m;
        }
        return;
      }
      case 2: {
        const double length = real(0.08, 0.25);
        const auto reply = controller.request(
            protocol::MeasureHandle{ajar::testing::base_point(1.45, -0.30, 1.0),
                                    ajar::testing::base_point(1.45, -0.30 - length, 1.0)});
        learn(controller, reply);
        if (const auto* ack = std::get_if<protocol::Ack>(&reply)) {
          stored_.handle_m = std::get<protocol::SpanAck>(ack->body).length_m;
        }
        return;
      }
      case 3: {
        const auto reply = controller.request(ajar::testing::plane_at_yaw(real(-0.3, 0.3)));
        learn(controller, reply);
        if (std::holds_alternative<protocol::Ack>(reply)) stored_.plane = true;
        return;
      }
      case 4:
        learn(controller, controller.request(protocol::AlignBase{}));
        return;
      case 5: {
        const int updates = uniform(1, 3);
        for (int i = 0; i < updates; ++i) {
          learn(controller, controller.request(protocol::Drive{real(-0.2, 0.2), real(-0.3, 0.3)}));
          std::this_thread::sleep_for(std::chrono::milliseconds(uniform(0, 60)));
        }
        return;
      }
      case 6:
        learn(controller, controller.request(protocol::Stop{}));
        return;
      case 7:
        learn(controller, controller.request(protocol::EmergencyStop{}));
        return;
      case 8: {
        const bool clear = chance(0.2);
        if (clear) trace_ << "-clear";
        const auto reply = controller.request(protocol::Reset{clear});
        learn(controller, reply);
        if (std::holds_alternative<protocol::Ack>(reply)) {
          fault_ = ErrorCode::kOk;
          if (clear) stored_ = Stored{};
          ++counters["resets"];
        }
        return;
      }
      case 9:
        learn(controller, controller.request(protocol::GetStatus{}));
        return;
      default:
        std::this_thread::sleep_for(std::chrono::milliseconds(uniform(0, 120)));
        learn(controller, controller.request(protocol::Ping{1}));
        return;
    }
  }

  void end(AjardProcess& ajard, TestClient& controller, TestClient& observer) {
    const auto ending = static_cast<Ending>(uniform(0, static_cast<int>(Ending::kCount) - 1));
    trace_ << " | " << kEndingNames[static_cast<int>(ending)];
    ++counters[kEndingNames[static_cast<int>(ending)]];
    allowed_ = {stored_};
    switch (ending) {
      case Ending::kKill:
        break;
      case Ending::kKillOnHungDisk:
        ASSERT_TRUE(hang_disk(state_dir_));
        [[fallthrough]];
      case Ending::kKillAfterEstopAck: {
        const auto reply = try_request(controller, protocol::EmergencyStop{});
        ASSERT_TRUE(is_ack(reply));
        learn(controller, *reply);
        break;
      }
      case Ending::kKillInFlight: {
        double length = 0;
        controller.send(random_width(length));
        Stored after = stored_;
        after.width_m = length;
        allowed_.push_back(after);
        // 0 to 3 ms: killed before the daemon read it, while it saves, or after the save.
        std::this_thread::sleep_for(std::chrono::microseconds(uniform(0, 3000)));
        break;
      }
      case Ending::kTerm:
      case Ending::kTermThenEstop:
      case Ending::kTermThenStop:
        terminate(ajard, controller, observer, ending);
        return;
      case Ending::kCount:
        break;
    }
    ajard.signal(SIGKILL);
    EXPECT_EQ(ajard.wait_exit(), 128 + SIGKILL);
    resume_disk(state_dir_);
    killed_ = true;
  }

  void terminate(AjardProcess& ajard, TestClient& controller, TestClient& observer, Ending ending) {
    // The observer's events so far are old news (the controller learned them from its own): a
    // round trip marks where the new ones begin.
    EXPECT_TRUE(try_request(observer, protocol::Ping{1}));
    observer.events().clear();
    ajard.signal(SIGTERM);
    if (ending != Ending::kTerm) {
      TestClient& who = ending == Ending::kTermThenEstop ? observer : controller;
      const protocol::Message stop = ending == Ending::kTermThenEstop
                                         ? protocol::Message(protocol::EmergencyStop{})
                                         : protocol::Message(protocol::Stop{});
      const auto reply = try_request(who, stop);
      if (reply) {  // else the shutdown was over already (the session closed unanswered)
        EXPECT_TRUE(is_ack(reply))
            << "a stop during the shutdown got" << TestClient::describe(*reply);
        learn(who, *reply);
        ++counters[ending == Ending::kTermThenEstop ? "estops acknowledged during the shutdown"
                                                    : "stops acknowledged during the shutdown"];
      } else {
        ++counters["stops unanswered: the shutdown had closed the session"];
      }
    }
    EXPECT_TRUE(controller.wait_closed());
    EXPECT_TRUE(observer.wait_closed());
    controller.close();  // the daemon waits for the peers' close (bounded) before it exits
    observer.close();
    learn(controller, protocol::Message(protocol::Pong{}));
    learn(observer, protocol::Message(protocol::Pong{}));
    EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
    killed_ = false;
  }

  std::mt19937_64 rng_;
  std::string dir_;
  std::ostream& trace_;
  std::string config_;
  std::string state_dir_;
  // The model: what the client knows (kInternal: a fault is latched, its code not known yet).
  ErrorCode fault_ = ErrorCode::kOk;
  Stored stored_;
  std::vector<Stored> allowed_{Stored{}};
  bool killed_ = false;
};

TEST(CrashCampaign, AFaultSurvivesEveryEndingNothingMovesBeforeAResetNoAcceptedMeasurementIsLost) {
  const char* one = std::getenv("AJAR_SEED");
  const std::uint64_t seed =
      one != nullptr ? env_u64("AJAR_SEED", 1)
                     : static_cast<std::uint64_t>(
                           std::chrono::steady_clock::now().time_since_epoch().count()) %
                           1000000;
  const std::uint64_t rounds = env_u64("AJAR_CRASH_ROUNDS", kCiRounds);
  std::cout << "crash campaign: seed " << seed << ", " << rounds
            << " rounds (replay with AJAR_SEED=" << seed << ")\n";
  ajar::testing::TempDir dir;
  std::ostringstream trace;
  Campaign campaign(seed, dir.path(), trace);
  for (std::uint64_t n = 0; n < rounds && !::testing::Test::HasFailure(); ++n)
    campaign.round(n);
  if (::testing::Test::HasFailure()) {
    ADD_FAILURE() << "seed " << seed << ", trace:\n"
                  << trace.str() << "replay with AJAR_SEED=" << seed;
  }
  std::cout << "counters over " << rounds << " rounds:\n";
  for (const auto& [name, count] : campaign.counters)
    std::cout << "  " << name << ": " << count << "\n";
}

}  // namespace
}  // namespace ajar::test
