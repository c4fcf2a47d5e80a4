// The interleaving proof's world (interleaving_test.cpp): one seed's engine over the
// deterministic mock card and the mock arm behind the real SessionHub, on a fake clock. Its jobs
// live in five files: the sessions (world_sessions.cpp), the random scenario
// (world_scenario.cpp), the invariants checked after every command and cycle
// (world_checks.cpp), the card's misbehaviour and limits (world_card.cpp), and the arm
// controller's faults with the arm interlock (world_arm.cpp).
#pragma once

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "ajar/drivers/mock_card.hpp"
#include "det_mock_card.hpp"
#include "fake_clock.hpp"
#include "fake_door.hpp"
#include "fake_engine_fixture.hpp"
#include "harness.hpp"

namespace ajar::testing::interleaving {

using protocol::EventKind;
using protocol::MessageType;
using protocol::ProcedureState;

// One seed's world: the engine over the deterministic mock card and the mock arm behind the
// SessionHub, the clock, and the model the invariants are checked against.
class World {
 public:
  World(std::uint64_t seed, const std::string& dir, bool verbose) : rng_(seed), verbose_(verbose) {
    config_ = test_config(dir);
    config_.state.directory = dir + "/state-" + std::to_string(seed % 8);
    config_.recorder.enabled = false;  // thousands of seeds: the black box is tested elsewhere
    config_.safety.deadman_timeout_s = 0.05;
    config_.control.motion_timeout_margin_s = 0.2;
    config_.safety.arm_task_timeout_s = 1.0;
    config_.safety.arm_stop_timeout_s = seed % 2 == 0 ? 0.04 : 0.15;
    // Jogs end sooner than with the defaults on most seeds (CPU); the defaults on some.
    if (seed % 4 != 0) {
      config_.drive.command_timeout_s = seed % 4 == 1 ? 0.1 : 0.2;
      config_.drive.max_linear_accel_m_s2 = 1.5;
      config_.drive.max_angular_accel_rad_s2 = 3.0;
    }
    // A slow state store on some seeds: saves lag behind (writer thread); durable Acks are held,
    // nothing else may wait on it.
    if (seed % 5 == 0) config_.state.debug_write_delay_ms = static_cast<int>(1 + seed % 3);
    left_axis_ = config_.base.left.card_axis;
    right_axis_ = config_.base.right.card_axis;
    auto card = make_det_card(clock_);
    card_ = card.get();
    card_->set_enable_delay_reads(static_cast<int>(rng_() % 3));
    init_card_limits(seed);
    calm_ = seed % 3 == 0;
    // The wheels at the configured speed (constant): an alignment lasts a hundred cycles or so.
    const auto profile = daemon::wheel_profile(config_.base);
    max_wheel_counts_per_ms_ = profile.velocity_counts_per_ms;
    counts_per_ms_per_rad_s_ = profile.velocity_counts_per_ms / config_.base.max_wheel_speed_rad_s;
    const auto& d = config_.drive;
    jog_bound_ns_ = static_cast<std::int64_t>(
                        (d.command_timeout_s +
                         std::max(d.max_linear_speed_m_s / d.max_linear_accel_m_s2,
                                  d.max_angular_speed_rad_s / d.max_angular_accel_rad_s2)) *
                        1e9) +
                    3 * kPeriodNs;
    drivers::DriverSet set;
    set.card = std::move(card);
    // The arm on the world's clock (a seed replays exactly): tasks stay busy until the scenario
    // says; a silent controller shows as disconnected 40 ms later.
    auto arm = std::make_unique<drivers::MockManipulator>(drivers::MockArmFault::kStuck, 40,
                                                          clock_.clock());
    arm_ = arm.get();
    set.arm = std::move(arm);
    daemon::EngineOptions options;
    options.now_ns = clock_.clock();
    options.manual_loop = true;
    std::filesystem::remove_all(config_.state.directory);
    engine_ = daemon::make_engine(config_, std::move(set), std::move(options));
    recorder_ = std::make_unique<FakeEngine>(*engine_);
    recorder_->before_lost = [this] { stop_expected(false, "controller lost"); };
    hub_ = std::make_unique<daemon::SessionHub>(*recorder_);
    engine_->set_event_sink([this](const protocol::Event& e) {
      on_event(e);
      hub_->on_event(e);
    });
    engine_->start();
    controller_ = connect(protocol::Role::kController, false, 0x1000 + seed);
    observer_ = connect(protocol::Role::kObserver, false, 0);
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
  const Coverage& coverage() const { return coverage_; }

 private:
  // ---- sessions (world_sessions.cpp) ----

  FakeLink* connect(protocol::Role role, bool take_over, std::uint64_t instance);

  void disconnect(FakeLink* link, const char* why);

  // One read from a link: its frames go through the hub in one engine batch. Each frame is either
  // a new request or a repeat of the last one (same request id).
  struct Frame {
    protocol::Message message;
    bool repeat = false;
    std::uint32_t request_id = 0;  // a repeat: the request it repeats
  };
  void read(FakeLink& link, const std::vector<Frame>& frames);
  void read(FakeLink& link, std::initializer_list<protocol::Message> messages);

  void deliver(FakeLink& link, const Frame& f);

  // The replies a link received: each request gets exactly one, in request order, with the
  // engine's reply (or, for a repeat, the recorded one).
  void drain(FakeLink& link);
  static bool has_reply(const FakeLink& link, std::uint32_t request_id);
  void drain_all();

  // ---- the scenario (world_scenario.cpp) ----

  void step();

  Frame random_command();

  protocol::Drive random_drive();

  protocol::Approach random_approach();

  protocol::Message next_procedure_step();

  // The operator's drive keys: pressed (the client re-sends the Drive while held), released (a
  // zero Drive), or the client simply stops sending (the command timeout must end the jog).
  void key_action();

  void observer_action();

  void lose_controller();

  void inject_card_fault();

  void arm_event();

  // ---- the arm controller's faults and the arm interlock (world_arm.cpp) ----

  // It stops answering mid-task, will not answer the next stop, resets mid-task, answers stops
  // but stays busy (now during a task, or by time in the next one) — or answers again (its link
  // back, idle).
  void inject_arm_fault();

  // Quiescing: the arm answers again, stops act, its link is back.
  void arm_clears_up();

  // The world's own view of the arm: "at the door" from every task handed off until the arm
  // reports idle. Read from the mock itself, never from the engine.
  void observe_arm();

  // Every cycle and after every read: while the arm may be at the door no wheel motion reaches the
  // card (no move, no jog with a speed) and the simulated wheels do not turn.
  void check_arm_interlock();

  // After a command: AlignBase, Drive, Approach accepted while the arm may be at the door fail;
  // coverage of the interlock's refusals.
  void check_arm_on_executed(const protocol::Message& m, const protocol::Message& reply);

  // A Reset may be refused only by the arm (field `arm`), with a fault latched, while the arm does
  // not report idle (it still stopped everything).
  bool reset_refused_by_the_arm(const protocol::Message& reply, const protocol::Status& before);

  // Everything clears up: a controller speaks, the card answers, the arm finishes, the key is
  // released. Within a bounded time nothing moves any more, every motion is closed, a Reset
  // recovers everything, and every request got its reply (held ones once their save settled).
  void quiesce();

  // ---- what a command did, the loop, the invariants (world_checks.cpp) ----

  void on_executed(const protocol::Message& m, const protocol::Message& reply,
                   const protocol::Status& before, std::ostringstream& line);

  void cycle(bool poll);

  void stop_expected(bool emergency, const char* why);

  bool card_jogging();

  void on_card_call(const drivers::CardCallRecord& c);

  // The jog seen from the outside after a cycle: the commanded body velocity (Status) within the
  // drive limits, changing no faster than the acceleration limits (it drops to zero at once only
  // in a cycle that stopped the card), and no wheel jogging past the command timeout.
  void check_jog(bool stop_call);

  void on_event(const protocol::Event& e);

  void check_now();

  // ---- the card's faults and the limits at the card (world_card.cpp) ----

  // The drive limits on some seeds below the wheels' (an Approach then has its own, slower
  // profile), the card's motion model (the trapezoid model on some seeds: its accelerations are
  // checked), and each motion kind's limits at the wheel from the config.
  void init_card_limits(std::uint64_t seed);
  // A card that misbehaves at a random cycle: it drops (accepts, does not apply) the next move,
  // jog update(s) or smooth stop, takes one and answers an error, reports stale status, or does
  // not answer at all (the emergency stop too) for a few cycles while its motion goes on.
  void inject_card_misbehaviour();
  void clear_card_misbehaviour();
  // What the card is told, per call: a move's trapezoid within the limits of its kind (AlignBase:
  // the wheel limits; Approach: also the body's), a jog's speed and ramp within the drive limits;
  // and by when the wheels must be at rest after it (the motion's deadline).
  void check_card_call(const drivers::CardCallRecord& c, bool straight);
  // What the simulated wheels do after a cycle: speed (and on the trapezoid model's seeds,
  // acceleration) within the running motion's limits; at rest by its deadline unless the card is
  // silent; a jog update the card did not apply is caught.
  void check_wheels(bool halted);
  // With a fresh door distance, a jog stops at drive.approach_min_standoff_m (issue 23).
  void check_door_guard();

  void fail(const std::string& what);
  void note(const std::string& line);
  int pick(int n);

  // ---- the world ----

  std::mt19937_64 rng_;
  bool verbose_;
  daemon::Config config_;
  FakeClock clock_;  // the world's one clock: the engine's, the card's, the arm's
  std::int64_t now() const { return clock_.now_ns(); }
  std::uint64_t tick_ = 0;
  drivers::MockMotionCard* card_ = nullptr;  // the engine's
  int left_axis_ = 1, right_axis_ = 2;
  bool stops_never_rest_ = false;
  drivers::MockManipulator* arm_ = nullptr;  // the engine's
  std::unique_ptr<daemon::Engine> engine_;
  std::unique_ptr<FakeEngine> recorder_;
  std::unique_ptr<daemon::SessionHub> hub_;
  std::vector<std::unique_ptr<FakeLink>> links_;
  std::uint64_t next_link_id_ = 1;
  std::uint32_t next_request_ = 1;
  FakeLink* controller_ = nullptr;
  FakeLink* observer_ = nullptr;
  struct Sent {  // a request that reached the engine
    std::uint64_t link_instance = 0;
    protocol::Message message;
    protocol::Message reply;
  };
  std::map<std::uint32_t, Sent> sent_;
  std::uint32_t last_request_ = 0;

  bool calm_ = false;
  bool alive_ = true;
  std::optional<protocol::Drive> key_;
  int key_every_ = 10, key_count_ = 0;
  protocol::PlaneAck plane_;
  double plane_yaw_odometry_rad_ = 0;  // odometry when plane_ was measured
  struct AllowedMove {
    std::int64_t left = 0, right = 0;
    bool straight = false;  // an Approach (else AlignBase's turn)
  };
  std::deque<AllowedMove> allowed_moves_;
  bool jog_permit_ = false;         // a Drive was accepted since the last acknowledged stop
  std::int64_t last_drive_ns_ = 0;  // when the last Drive was accepted
  std::int64_t jog_bound_ns_ = 0;   // timeout + deceleration (+ margin) after the last Drive
  double max_wheel_counts_per_ms_ = 0, counts_per_ms_per_rad_s_ = 0;
  double jog_left_ = 0, jog_right_ = 0;  // the last jog velocities the card got (counts/ms)
  std::int64_t last_jog_ns_ = 0;
  double commanded_lin_ = 0, commanded_ang_ = 0;  // Status commanded_* after the last cycle
  bool stop_due_ = false, estop_due_ = false;
  std::size_t stop_call_ = 0;  // the card's log size at the last acknowledged stop
  int motion_open_ = 0;
  char open_kind_ = 0;  // the open motion: 'a'lign, a'p'proach, 'd'rive, 'e'ngage
  bool fault_event_open_ = false;
  // The card's faults and the limits at the card (world_card.cpp): counts/ms and counts/ms^2 at a
  // wheel for each motion kind.
  struct KindLimits {
    double speed = 0, accel = 0;
  };
  KindLimits turn_limits_, straight_limits_, jog_limits_;
  bool profile_model_ = false;    // the card ramps (trapezoid model): accelerations are checked
  char wheel_kind_ = 0;           // the motion the wheels run: 't'urn, 's'traight, 'j'og, 0 none
  std::int64_t rest_by_ns_ = 0;   // the wheels rest by then (the running motion's deadline)
  bool rest_by_drive_ = false;    // that deadline follows the last accepted Drive (a jog)
  std::int64_t jog_rest_ns_ = 0;  // after the last accepted Drive, for a jog
  std::int64_t silent_until_ns_ = 0;
  double wheel_v_[2] = {0, 0};    // the simulated wheels after the last cycle (counts/ms)
  double jog_told_[2] = {0, 0};   // the jog velocities the card was last told
  bool jog_told_active_ = false;  // the last motion call was a jog
  std::int64_t disagree_since_[2] = {-1, -1};
  bool card_halted_ = false;         // an injected fault halted a wheel since the last check
  bool stuck_move_pending_ = false;  // the next move sticks (stick_next_move)
  double guard_distance_m_ = 0;      // the fresh door distance after the last cycle (else inf)
  ErrorCode last_fault_ = ErrorCode::kOk;
  bool reset_seen_ = false;
  bool arm_at_door_ = true;  // unknown until the arm's first idle report
  std::uint64_t arm_tasks_seen_ = 0;
  std::size_t arm_log_seen_ = 0;      // the card's log checked by check_arm_interlock
  bool arm_silence_on_stop_ = false;  // the next silence is the stop's (coverage)
  bool arm_was_silent_ = false;
  std::uint64_t arm_stops_seen_ = 0;
  drivers::ArmPhase arm_last_phase_ = drivers::ArmPhase::kIdle;
  Coverage coverage_;
  std::vector<std::string> trace_;
  std::string violation_;
};

}  // namespace ajar::testing::interleaving
