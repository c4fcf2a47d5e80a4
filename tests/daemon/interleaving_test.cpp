// Randomized interleavings of the engine and its control loop on a fake clock: commands arrive in
// batches between two loop cycles (as if several frames came in one read), with Stop, EmergencyStop
// and Reset at random points, duplicates, controller loss and take-over, silence (deadman), card
// faults at random cycles (DetCard's menu), a slow state store, and arm outcomes (done, fault,
// disconnect, a controller that resets mid-task). The loop runs by hand
// (EngineOptions::manual_loop), so a seed replays exactly. After every command and every cycle the
// invariants below are checked.
//
//   AJAR_SEED=<n>     replay one seed (prints its trace)
//   AJAR_SEEDS=<n>    number of seeds (default 2000; a campaign: AJAR_SEEDS=200000)
#include <gtest/gtest.h>

#include <cstdlib>
#include <deque>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/engine.hpp"
#include "det_card.hpp"
#include "fake_door.hpp"
#include "fake_manipulator.hpp"

namespace ajar::testing {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;

constexpr std::int64_t kPeriodNs = 2'000'000;  // 500 Hz

std::string shm_dir() {
  // State files on tmpfs when available: thousands of engines each persist dozens of times.
  std::string pattern = std::filesystem::exists("/dev/shm") ? "/dev/shm/ajar-interleave-XXXXXX"
                                                            : "/tmp/ajar-interleave-XXXXXX";
  return ::mkdtemp(pattern.data()) != nullptr ? pattern : std::string("/tmp");
}

// One seed's world: the engine over DetCard and the fake arm, the clock, and the model the
// invariants are checked against.
class World {
 public:
  World(std::uint64_t seed, const std::string& dir, bool verbose) : rng_(seed), verbose_(verbose) {
    config_ = test_config(dir);
    config_.state.directory = dir + "/state-" + std::to_string(seed % 8);
    config_.safety.deadman_timeout_s = 0.05;
    config_.control.motion_timeout_margin_s = 0.2;
    config_.safety.arm_task_timeout_s = 1.0;
    // A slow state store on some seeds: saves lag behind (writer thread); nothing may wait on it.
    if (seed % 5 == 0) config_.state.debug_write_delay_ms = static_cast<int>(1 + seed % 3);
    card_.now_ns = &now_;
    card_.tick = &tick_;
    card_.left_axis = config_.base.left.card_axis;
    card_.right_axis = config_.base.right.card_axis;
    card_.enable_delay_reads = static_cast<int>(rng_() % 3);
    // The wheels at the configured speed: an alignment lasts a hundred cycles or so.
    card_.speed_counts_per_ns = daemon::wheel_profile(config_.base).velocity_counts_per_ms / 1e6;
    drivers::DriverSet set;
    set.card = std::make_unique<DetCard>(card_);
    set.arm = std::make_unique<FakeManipulator>(arm_);
    daemon::EngineOptions options;
    options.now_ns = [this] { return now_; };
    options.manual_loop = true;
    std::filesystem::remove_all(config_.state.directory);
    engine_ = daemon::make_engine(config_, std::move(set), std::move(options));
    engine_->set_event_sink([this](const protocol::Event& e) { on_event(e); });
    engine_->start();
  }
  ~World() {
    if (engine_) engine_->shutdown();
  }

  // The whole scenario; returns the first violation (empty: none).
  std::string run(int steps) {
    for (int i = 0; i < steps && violation_.empty(); ++i)
      step();
    if (violation_.empty()) quiesce();
    return violation_;
  }
  const std::vector<std::string>& trace() const { return trace_; }

 private:
  // ---- the scenario ----------------------------------------------------------------------------

  void step() {
    const int what = pick(100);
    if (what < 55) {
      const int n = 1 + pick(4);  // several frames in one read
      for (int i = 0; i < n && violation_.empty(); ++i)
        send(random_command());
    } else if (what < 60) {
      note("controller lost (disconnect or take-over)");
      stop_expected(/*emergency=*/false, "controller lost");
      engine_->controller_lost();
      alive_ = pick(2) == 0;  // a take-over: the new controller speaks; else silence
      check_now();
    } else if (what < 63) {
      alive_ = !alive_;
      note(alive_ ? "controller speaks again" : "controller goes silent");
    } else if (what < 73) {
      inject_card_fault();
    } else if (what < 83) {
      arm_event();
    }
    const int cycles = 1 + pick(what < 90 ? 4 : 40);
    for (int i = 0; i < cycles && violation_.empty(); ++i)
      cycle(pick(3) != 0);
  }

  protocol::Message random_command() {
    const int what = pick(100);
    if (what < 8 && last_command_) {
      note("duplicate:");
      return *last_command_;
    }
    protocol::Message m;
    if (what < 22) {
      m = next_procedure_step();
    } else if (what < 36) {
      m = protocol::AlignBase{};
    } else if (what < 46) {
      m = protocol::Stop{};
    } else if (what < 52) {
      m = protocol::EmergencyStop{};
    } else if (what < 64) {
      m = protocol::Reset{pick(6) == 0};
    } else if (what < 76) {
      m = plane_at_yaw((pick(2) == 0 ? -1 : 1) * (0.01 + 0.01 * pick(12)));
    } else if (what < 84) {
      m = protocol::Engage{};
    } else if (what < 90) {
      m = good_contact();
    } else if (what < 95) {
      m = good_width();
    } else {
      m = good_handle();
    }
    last_command_ = m;
    return m;
  }

  protocol::Message next_procedure_step() {
    switch (engine_->status().state) {
      case ProcedureState::kAwaitingWidth:
        return good_width();
      case ProcedureState::kAwaitingHandle:
        return good_handle();
      case ProcedureState::kAwaitingPlane:
      case ProcedureState::kReadyToAlign:
        return pick(2) == 0 ? protocol::Message{plane_at_yaw(0.05 + 0.01 * pick(8))}
                            : protocol::Message{protocol::AlignBase{}};
      case ProcedureState::kAligned:
        return good_contact();
      case ProcedureState::kReadyToEngage:
        return protocol::Engage{};
      case ProcedureState::kFault:
        return protocol::Reset{false};
      default:
        return protocol::Stop{};
    }
  }

  void inject_card_fault() {
    const int axis = pick(2) == 0 ? card_.left_axis : card_.right_axis;
    switch (pick(7)) {
      case 0:
        note("card: drive alarm on axis " + std::to_string(axis));
        card_.inject_alarm(axis);
        break;
      case 1:
        note("card: following error on axis " + std::to_string(axis));
        card_.inject_following_error(axis);
        break;
      case 2:
        note("card: limit on axis " + std::to_string(axis));
        card_.inject_limit(axis);
        break;
      case 3:
        card_.fail_calls = 1 + pick(8);
        note("card: not answering for " + std::to_string(card_.fail_calls) + " calls");
        break;
      case 4:
        note("card: refuses the next move");
        card_.refuse_next_move = true;
        break;
      case 5:
        note("card: the next move never progresses");
        card_.stick_next_move = true;
        break;
      default:
        card_.stops_never_rest = !card_.stops_never_rest;
        note(std::string("card: smooth stops ") +
             (card_.stops_never_rest ? "never rest" : "rest again"));
        break;
    }
  }

  void arm_event() {
    const auto st = arm_->with_lock([](FakeArmControl& a) { return a.status; });
    if (st.phase != drivers::ArmPhase::kBusy) return;
    switch (pick(4)) {
      case 0:
        note("arm: task done");
        arm_->set_phase(drivers::ArmPhase::kDone);
        break;
      case 1:
        note("arm: fault");
        arm_->set_phase(drivers::ArmPhase::kFault, ErrorCode::kArmFault);
        break;
      case 2:
        note("arm: disconnected");
        arm_->set_phase(drivers::ArmPhase::kDisconnected, ErrorCode::kArmDisconnected);
        break;
      default:
        note("arm: controller reset mid-task (busy -> idle)");
        arm_->set_phase(drivers::ArmPhase::kIdle);
        break;
    }
  }

  // Everything clears up: the controller speaks, the card answers, the arm finishes. Within a
  // bounded time nothing moves any more, every motion is closed, and a Reset recovers everything.
  void quiesce() {
    note("quiesce");
    alive_ = true;
    card_.fail_calls = 0;
    card_.stops_never_rest = false;
    // Bounded: every deadline (motion, stop, arm task, recovery) is far shorter.
    const auto settled = [&] {
      const auto st = engine_->status().state;
      return !card_.any_moving() && motion_open_ == 0 && st != ProcedureState::kAligning &&
             st != ProcedureState::kEngaging;
    };
    for (int i = 0; i < 3000 && violation_.empty() && !settled(); ++i)
      cycle(true);
    if (engine_->status().latched_fault != ErrorCode::kOk) send(protocol::Reset{});
    for (int i = 0; i < 1000 && violation_.empty(); ++i) {
      cycle(true);
      if (i >= 20 && settled() && engine_->status().card == protocol::DriverState::kActive) break;
    }
    if (!violation_.empty()) return;
    const auto status = engine_->status();
    if (card_.any_moving()) return fail("the wheels still move after quiescing");
    if (motion_open_ != 0) return fail("a motion_started was never closed");
    if (status.state == ProcedureState::kAligning || status.state == ProcedureState::kEngaging) {
      return fail(std::string("still ") + std::string(protocol::to_string(status.state)));
    }
    if (status.latched_fault == ErrorCode::kOk && status.card != protocol::DriverState::kActive) {
      return fail("no fault latched but the card is not active after a Reset");
    }
    if ((status.latched_fault != ErrorCode::kOk) != fault_event_open_) {
      return fail("latched fault and fault_latched events disagree");
    }
  }

  // ---- actions ---------------------------------------------------------------------------------

  void send(const protocol::Message& m) {
    ++tick_;
    const auto before = engine_->status();
    const bool is_stop = std::holds_alternative<protocol::Stop>(m) ||
                         std::holds_alternative<protocol::EmergencyStop>(m) ||
                         std::holds_alternative<protocol::Reset>(m);
    engine_->controller_heartbeat();
    const protocol::Message reply = engine_->handle_command(m);
    const auto* ack = std::get_if<protocol::Ack>(&reply);
    std::ostringstream line;
    line << "send " << protocol::to_string(protocol::type_of(m)) << " -> ";
    if (ack != nullptr) {
      line << "ack " << protocol::to_string(ack->state);
    } else if (const auto* e = std::get_if<protocol::ErrorReply>(&reply)) {
      line << "refused " << to_string(e->code);
    }
    note(line.str());
    if (is_stop) {
      if (ack == nullptr) return fail("a Stop/EmergencyStop/Reset was not acknowledged");
      stop_expected(std::holds_alternative<protocol::EmergencyStop>(m), "acknowledged stop");
      if (std::holds_alternative<protocol::Reset>(m)) reset_seen_ = true;
    }
    if (const auto* p = std::get_if<protocol::MeasureDoorPlane>(&m); p && ack) {
      plane_ = std::get<protocol::PlaneAck>(ack->body);
      plane_yaw_odometry_rad_ = before.base_yaw_odometry_rad;
    }
    if (std::holds_alternative<protocol::AlignBase>(m) && ack &&
        ack->state == ProcedureState::kAligning) {
      if (before.latched_fault != ErrorCode::kOk) fail("AlignBase accepted with a fault latched");
      // The plane's yaw seen from where the base is now (a stop may have let it turn on since).
      const double turned = before.base_yaw_odometry_rad - plane_yaw_odometry_rad_;
      const auto wheels = core::wheel_command(plane_.yaw_deviation_rad - turned, config_.base);
      allowed_moves_.push_back(turned == 0 ? std::pair{plane_.left_counts, plane_.right_counts}
                                           : std::pair{wheels.left_counts, wheels.right_counts});
    }
    check_now();
  }

  void cycle(bool poll) {
    ++tick_;
    now_ += kPeriodNs;
    if (alive_) engine_->controller_heartbeat();
    const std::size_t calls_before = card_.calls.size();
    engine_->run_loop_cycle();
    for (std::size_t i = calls_before; i < card_.calls.size(); ++i)
      on_card_call(card_.calls[i]);
    // One period after an acknowledged stop: the wheels are commanded to stop.
    if (stop_due_) {
      stop_due_ = false;
      if (estop_due_) {
        estop_due_ = false;
        bool reached = false;
        for (const auto& c : card_.calls)
          reached =
              reached || (c.kind == DetCardState::Call::kEmergencyStop && c.tick > stop_tick_);
        if (!reached)
          return fail("an acknowledged EmergencyStop did not reach the card in one period");
      }
      for (auto& [n, a] : card_.axes) {
        card_.advance(a);
        if (a.moving && !a.stopping && a.move_tick < stop_tick_) {
          return fail("the wheels were not commanded to stop within one period of a stop");
        }
      }
    }
    if (poll) engine_->poll();
    check_now();
  }

  void stop_expected(bool emergency, const char* why) {
    (void)why;
    allowed_moves_.clear();  // moves accepted before a stop may never start
    stop_due_ = true;
    estop_due_ = estop_due_ || emergency;
    stop_tick_ = tick_;
  }

  // ---- invariants ------------------------------------------------------------------------------

  void on_card_call(const DetCardState::Call& c) {
    if (c.kind != DetCardState::Call::kMove) return;
    note("card: move " + std::to_string(c.left) + ", " + std::to_string(c.right));
    if (allowed_moves_.empty()) {
      return fail("the card was told to move without an accepted AlignBase since the last stop");
    }
    const auto [left, right] = allowed_moves_.front();
    allowed_moves_.pop_front();
    if (left != c.left || right != c.right)
      return fail("the card moved other counts than accepted");
  }

  void on_event(const protocol::Event& e) {
    std::ostringstream line;
    line << "  event " << static_cast<int>(e.kind) << " " << e.detail.view();
    note(line.str());
    switch (e.kind) {
      case EventKind::kMotionStarted:
        if (motion_open_ != 0) fail("motion_started while another motion is open");
        ++motion_open_;
        break;
      case EventKind::kMotionFinished:
      case EventKind::kMotionStopped:
        if (motion_open_ == 0) fail("motion_finished/stopped without an open motion_started");
        if (motion_open_ > 0) --motion_open_;
        break;
      case EventKind::kFaultLatched:
        if (fault_event_open_) fail("a second fault_latched event for one latch");
        fault_event_open_ = true;
        break;
      case EventKind::kFaultCleared:
        fault_event_open_ = false;
        break;
      default:
        break;
    }
  }

  void check_now() {
    if (!violation_.empty()) return;
    const ErrorCode fault = engine_->status().latched_fault;
    if (last_fault_ != ErrorCode::kOk && fault != last_fault_ && !reset_seen_) {
      return fail("the latched fault " + std::string(to_string(last_fault_)) + " became " +
                  std::string(to_string(fault)) + " without a Reset");
    }
    if (fault != ErrorCode::kOk && !fault_event_open_) {
      return fail("a fault is latched but no fault_latched event was sent");
    }
    last_fault_ = fault;
    reset_seen_ = false;
  }

  void fail(const std::string& what) {
    if (violation_.empty()) violation_ = what;
  }
  void note(const std::string& line) {
    std::ostringstream out;
    out << '[' << tick_ << " t=" << now_ / 1'000'000 << "ms] " << line;
    trace_.push_back(out.str());
    if (verbose_) std::cerr << trace_.back() << "\n";
  }
  int pick(int n) { return static_cast<int>(rng_() % static_cast<std::uint64_t>(n)); }

  std::mt19937_64 rng_;
  bool verbose_;
  daemon::Config config_;
  std::int64_t now_ = 1'000'000'000;
  std::uint64_t tick_ = 0;
  DetCardState card_;
  std::shared_ptr<FakeArmControl> arm_ = std::make_shared<FakeArmControl>();
  std::unique_ptr<daemon::Engine> engine_;

  bool alive_ = true;
  std::optional<protocol::Message> last_command_;
  protocol::PlaneAck plane_;
  double plane_yaw_odometry_rad_ = 0;  // odometry when plane_ was measured
  std::deque<std::pair<std::int64_t, std::int64_t>> allowed_moves_;
  bool stop_due_ = false, estop_due_ = false;
  std::uint64_t stop_tick_ = 0;
  int motion_open_ = 0;
  bool fault_event_open_ = false;
  ErrorCode last_fault_ = ErrorCode::kOk;
  bool reset_seen_ = false;
  std::vector<std::string> trace_;
  std::string violation_;
};

std::uint64_t env_u64(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::strtoull(v, nullptr, 10) : fallback;
}

TEST(Interleaving, RandomCommandSequencesKeepTheSafetyInvariants) {
  const std::string dir = shm_dir();
  const char* one = std::getenv("AJAR_SEED");
  const std::uint64_t first = one != nullptr ? env_u64("AJAR_SEED", 0) : 1;
  const std::uint64_t count = one != nullptr ? 1 : env_u64("AJAR_SEEDS", 2000);
  int failures = 0;
  for (std::uint64_t seed = first; seed < first + count && failures < 3; ++seed) {
    World world(seed, dir, one != nullptr);
    const std::string violation = world.run(60);
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
  std::filesystem::remove_all(dir);
}

// The reported case: AlignBase and Stop in one read (before the loop's next cycle). The Stop is
// acknowledged, so the wheels must never turn.
TEST(Interleaving, AlignBaseAndStopInOneReadNeverTurn) {
  const std::string dir = shm_dir();
  DetCardState card;
  std::int64_t now = 1'000'000'000;
  std::uint64_t tick = 0;
  card.now_ns = &now;
  card.tick = &tick;
  auto config = test_config(dir);
  card.left_axis = config.base.left.card_axis;
  card.right_axis = config.base.right.card_axis;
  auto arm = std::make_shared<FakeArmControl>();
  drivers::DriverSet set;
  set.card = std::make_unique<DetCard>(card);
  set.arm = std::make_unique<FakeManipulator>(arm);
  daemon::EngineOptions options;
  options.now_ns = [&] { return now; };
  options.manual_loop = true;
  auto engine = daemon::make_engine(config, std::move(set), std::move(options));
  std::vector<protocol::Event> events;
  engine->set_event_sink([&](const protocol::Event& e) { events.push_back(e); });
  engine->start();
  const auto cycle = [&] {
    now += kPeriodNs;
    engine->controller_heartbeat();
    engine->run_loop_cycle();
    engine->poll();
  };
  for (int i = 0; i < 3; ++i)
    cycle();
  engine->handle_command(good_width());
  engine->handle_command(good_handle());
  engine->handle_command(plane_at_yaw(0.1));
  cycle();
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::AlignBase{})));
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::Stop{})));
  for (int i = 0; i < 200; ++i)
    cycle();
  int moves = 0;
  for (const auto& c : card.calls)
    moves += c.kind == DetCardState::Call::kMove ? 1 : 0;
  EXPECT_EQ(moves, 0) << "the wheels turned after an acknowledged Stop";
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToAlign);
  int started = 0, closed = 0;
  for (const auto& e : events) {
    started += e.kind == EventKind::kMotionStarted ? 1 : 0;
    closed += e.kind == EventKind::kMotionStopped || e.kind == EventKind::kMotionFinished ? 1 : 0;
  }
  EXPECT_EQ(started, 1);
  EXPECT_EQ(closed, 1);
  engine->shutdown();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ajar::testing
