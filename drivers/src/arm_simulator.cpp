#include "ajar/drivers/arm_simulator.hpp"

#include <pthread.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/eventfd.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace ajar::drivers {
namespace {

using Clock = std::chrono::steady_clock;

std::runtime_error sys_error(const std::string& what) {
  return std::runtime_error("arm simulator: " + what + ": " + std::strerror(errno));
}

// Garbage the driver must skip: noise, a '$' fragment, and a complete line with a wrong CRC.
constexpr char kGarbageBytes[] = "\x01\xFFnoise$17,AC\x7F\r\n$9,STA,IDLE,0*0000\r\n#";
constexpr std::string_view kGarbage{kGarbageBytes, sizeof kGarbageBytes - 1};

struct Injection {
  int count = 0;
  std::optional<arm::Command> only_for;
  bool take(arm::Command subject) {
    if (count <= 0 || (only_for && *only_for != subject)) return false;
    --count;
    return true;
  }
};

}  // namespace

struct ArmControllerSimulator::Impl {
  explicit Impl(ArmSimulatorSettings s) : settings(s) {}

  ArmSimulatorSettings settings;
  std::string dir;
  std::string link;

  // Owned by the simulator thread after start (and by the constructor / destructor around it).
  int master_fd = -1;
  int slave_fd = -1;
  int wake_fd = -1;
  arm::LineReader reader;
  std::thread thread;

  mutable std::mutex mutex;
  std::condition_variable plug_changed;
  bool quit = false;
  bool want_plugged = true;
  bool plugged = false;
  std::string plug_error;
  Injection corrupt;
  Injection drop;
  Injection garble;
  bool refuse = false;
  bool fail_task = false;
  // The controller's own faults (header).
  bool silent = false;
  std::optional<Clock::time_point> silent_until;  // empty: until answer_again()
  bool silence_next_stop = false;
  bool ignore_stops = false;
  bool hold_task = false;                   // a STOP was ignored: the task never ends
  std::optional<Clock::time_point> midway;  // silent / reset mid-task: when
  std::string raw_out;
  Counters counters;
  arm::ControllerPhase phase = arm::ControllerPhase::kIdle;
  std::uint32_t task_id = 0;
  std::optional<DoorTask> task;
  Clock::time_point task_done_at{};
  std::optional<std::uint16_t> last_seq;
  std::string last_reply;
  struct Outgoing {
    Clock::time_point due;
    std::string bytes;
  };
  std::deque<Outgoing> outgoing;

  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(wake_fd, &one, sizeof one);
  }

  void open_pair() {
    int m = -1;
    int s = -1;
    if (::openpty(&m, &s, nullptr, nullptr, nullptr) != 0) throw sys_error("openpty");
    termios tio{};
    ::tcgetattr(s, &tio);
    ::cfmakeraw(&tio);
    ::tcsetattr(s, TCSANOW, &tio);
    ::fcntl(m, F_SETFL, ::fcntl(m, F_GETFL) | O_NONBLOCK);
    char name[256] = {};
    if (::ttyname_r(s, name, sizeof name) != 0) {
      ::close(m);
      ::close(s);
      throw sys_error("ttyname_r");
    }
    // Atomic re-point: a new link next to the old one, renamed over it.
    const std::string tmp = link + ".new";
    ::unlink(tmp.c_str());
    if (::symlink(name, tmp.c_str()) != 0 || ::rename(tmp.c_str(), link.c_str()) != 0) {
      ::close(m);
      ::close(s);
      throw sys_error("symlink " + link);
    }
    master_fd = m;
    slave_fd = s;
    reader.clear();
  }

  void close_pair() {
    ::unlink(link.c_str());
    if (master_fd >= 0) ::close(master_fd);
    if (slave_fd >= 0) ::close(slave_fd);
    master_fd = -1;
    slave_fd = -1;
    reader.clear();
  }

  // --- protocol (mutex held) ---
  std::string reply_line(const arm::Message& m) const {
    auto line = arm::encode(m);
    return line ? std::move(line).value() : std::string{};
  }

  arm::Message make_reply(const arm::Message& req, Clock::time_point now) {
    arm::Message r;
    r.seq = req.seq;
    r.subject = req.command;
    r.command = arm::Command::kAck;
    switch (req.command) {
      case arm::Command::kTask: {
        const bool bad_fields =
            req.task.door_width_m <= 0 || req.task.handle_length_m < 0 || req.task_id == 0;
        auto nak = [&](arm::RejectReason reason) {
          r.command = arm::Command::kNak;
          r.reason = reason;
        };
        if (phase == arm::ControllerPhase::kBusy) {
          nak(arm::RejectReason::kBusy);
        } else if (phase == arm::ControllerPhase::kFault) {
          nak(arm::RejectReason::kFault);
        } else if (bad_fields) {
          nak(arm::RejectReason::kBadRequest);
        } else if (refuse) {
          nak(arm::RejectReason::kRefused);
        } else {
          phase = arm::ControllerPhase::kBusy;
          task_id = req.task_id;
          task = req.task;
          task_done_at = now + std::chrono::milliseconds(settings.task_duration_ms);
          fail_task = false;
          hold_task = false;
          ++counters.tasks_executed;
          midway.reset();
          if (settings.fault == ArmSimFault::kSilentMidTask ||
              settings.fault == ArmSimFault::kResetMidTask) {
            midway = now + std::chrono::milliseconds(settings.task_duration_ms / 2);
          }
          silence_next_stop = settings.fault == ArmSimFault::kSilentMidStop;
        }
        break;
      }
      case arm::Command::kStatus:
        r.command = arm::Command::kReport;
        break;
      case arm::Command::kStop:
        ++counters.stops;
        if (phase == arm::ControllerPhase::kBusy &&
            (ignore_stops || settings.fault == ArmSimFault::kStopIgnored)) {
          hold_task = true;  // answered, and it goes on working
        } else if (phase == arm::ControllerPhase::kBusy || phase == arm::ControllerPhase::kDone) {
          phase = arm::ControllerPhase::kIdle;
          midway.reset();
        }
        break;
      case arm::Command::kClear:
        if (phase == arm::ControllerPhase::kFault) phase = arm::ControllerPhase::kIdle;
        break;
      default:  // a controller message sent to the controller: ignored
        break;
    }
    r.phase = phase;
    r.task_id = task_id;
    return r;
  }

  void queue_reply(std::string line, arm::Command subject, Clock::time_point now) {
    if (drop.take(subject)) return;
    if (corrupt.take(subject) && line.size() >= 4) {
      char& digit = line[line.size() - 3];  // last CRC digit, before "\r\n"
      digit = digit == '0' ? '1' : '0';
    }
    if (garble.take(subject)) {
      line.insert(0, kGarbage);
    }
    outgoing.push_back({now + std::chrono::milliseconds(settings.reply_delay_ms), std::move(line)});
  }

  void handle_line(const std::string& text, Clock::time_point now) {
    auto decoded = arm::decode(text);
    if (!decoded) {
      ++counters.bad_requests;
      return;
    }
    const arm::Message& req = decoded.value();
    const bool request = req.command == arm::Command::kTask ||
                         req.command == arm::Command::kStatus ||
                         req.command == arm::Command::kStop || req.command == arm::Command::kClear;
    if (!request || req.seq == arm::kUnsolicitedSeq) {
      ++counters.bad_requests;
      return;
    }
    ++counters.requests;
    if (req.command == arm::Command::kStop && silence_next_stop &&
        phase == arm::ControllerPhase::kBusy) {
      silence_next_stop = false;
      fall_silent(now);
    }
    if (silent) {
      ++counters.unanswered;
      return;
    }
    if (last_seq && *last_seq == req.seq) {
      ++counters.duplicates_ignored;
      queue_reply(last_reply, req.command, now);
      return;
    }
    last_reply = reply_line(make_reply(req, now));
    last_seq = req.seq;
    queue_reply(last_reply, req.command, now);
  }

  void fall_silent(Clock::time_point now) {
    silent = true;
    silent_until.reset();
    if (settings.silent_ms > 0) silent_until = now + std::chrono::milliseconds(settings.silent_ms);
  }

  void reset_locked() {
    phase = arm::ControllerPhase::kIdle;
    task_id = 0;
    task.reset();
    last_seq.reset();
    last_reply.clear();
    outgoing.clear();
    silent = false;
    silence_next_stop = false;
    hold_task = false;
    fail_task = false;
    midway.reset();
  }

  void tick(Clock::time_point now) {
    if (silent && silent_until && now >= *silent_until) silent = false;
    if (silent) return;  // its task neither ends nor fails until it answers again
    if (phase != arm::ControllerPhase::kBusy) return;
    if (midway && now >= *midway) {
      midway.reset();
      if (settings.fault == ArmSimFault::kSilentMidTask) {
        fall_silent(now);
        return;
      }
      if (settings.fault == ArmSimFault::kResetMidTask) {
        reset_locked();
        return;
      }
    }
    if (hold_task) return;
    if (fail_task) {
      phase = arm::ControllerPhase::kFault;
      fail_task = false;
      return;
    }
    if (now < task_done_at) return;
    phase = arm::ControllerPhase::kDone;
    ++counters.tasks_completed;
    arm::Message done;
    done.seq = arm::kUnsolicitedSeq;
    done.command = arm::Command::kDone;
    done.task_id = task_id;
    outgoing.push_back({now, reply_line(done)});  // unsolicited: no fault injection
  }

  void write_master(const std::string& bytes) {
    if (master_fd < 0) return;
    std::size_t off = 0;
    while (off < bytes.size()) {
      const auto n = ::write(master_fd, bytes.data() + off, bytes.size() - off);
      if (n <= 0) {
        if (n < 0 && errno == EINTR) continue;
        return;  // buffer full (nobody reading) or hang-up: the bytes are lost, as on a wire
      }
      off += static_cast<std::size_t>(n);
    }
  }

  void run() {
    std::unique_lock lock(mutex);
    while (!quit) {
      // Plug changes requested by unplug()/replug().
      if (want_plugged != plugged) {
        if (plugged) {
          close_pair();
          plugged = false;
          outgoing.clear();
        } else {
          try {
            open_pair();
            plugged = true;
          } catch (const std::exception& e) {
            plug_error = e.what();
            want_plugged = false;
          }
        }
        plug_changed.notify_all();
      }
      const auto now = Clock::now();
      tick(now);
      std::string to_write;
      to_write.swap(raw_out);
      while (!outgoing.empty() && outgoing.front().due <= now) {
        to_write += outgoing.front().bytes;
        outgoing.pop_front();
      }
      if (!plugged) to_write.clear();
      // Next deadline: a due reply or the running task's end.
      auto timeout_ms = 50;
      auto until = [&](Clock::time_point t) {
        const auto ms = std::chrono::ceil<std::chrono::milliseconds>(t - now).count();
        if (ms < timeout_ms) timeout_ms = static_cast<int>(ms < 0 ? 0 : ms);
      };
      if (!outgoing.empty()) until(outgoing.front().due);
      if (phase == arm::ControllerPhase::kBusy && !silent && !hold_task) until(task_done_at);
      if (midway && !silent && phase == arm::ControllerPhase::kBusy) until(*midway);
      if (silent && silent_until) until(*silent_until);
      const int master = plugged ? master_fd : -1;
      lock.unlock();

      write_master(to_write);
      pollfd fds[2] = {{wake_fd, POLLIN, 0}, {master, POLLIN, 0}};
      ::poll(fds, master >= 0 ? 2 : 1, timeout_ms);
      if ((fds[0].revents & POLLIN) != 0) {
        std::uint64_t count = 0;
        [[maybe_unused]] const auto n = ::read(wake_fd, &count, sizeof count);
      }
      std::string in;
      if (master >= 0 && (fds[1].revents & POLLIN) != 0) {
        char buf[512];
        const auto n = ::read(master, buf, sizeof buf);
        if (n > 0) in.assign(buf, static_cast<std::size_t>(n));
      }

      lock.lock();
      if (!in.empty()) {
        reader.feed(in);
        const auto t = Clock::now();
        while (auto line = reader.next_line())
          handle_line(*line, t);
      }
    }
  }

  void set_plugged(bool value) {
    std::unique_lock lock(mutex);
    want_plugged = value;
    plug_error.clear();
    wake();
    plug_changed.wait(lock, [&] { return plugged == want_plugged || quit; });
    if (!plug_error.empty()) throw std::runtime_error(plug_error);
  }
};

ArmControllerSimulator::ArmControllerSimulator(ArmSimulatorSettings settings)
    : impl_(std::make_unique<Impl>(settings)) {
  const auto base = std::filesystem::temp_directory_path() / "ajar-armsim-XXXXXX";
  std::string tmpl = base.string();
  if (::mkdtemp(tmpl.data()) == nullptr) throw sys_error("mkdtemp " + tmpl);
  impl_->dir = tmpl;
  impl_->link = tmpl + "/arm";
  impl_->wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (impl_->wake_fd < 0) {
    ::rmdir(impl_->dir.c_str());
    throw sys_error("eventfd");
  }
  try {
    impl_->open_pair();
  } catch (...) {
    ::close(impl_->wake_fd);
    ::rmdir(impl_->dir.c_str());
    throw;
  }
  impl_->plugged = true;
  impl_->thread = std::thread([impl = impl_.get()] {
    pthread_setname_np(pthread_self(), "ajar-arm-sim");
    impl->run();
  });
}

ArmControllerSimulator::~ArmControllerSimulator() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->quit = true;
    impl_->wake();
  }
  impl_->plug_changed.notify_all();
  impl_->thread.join();
  impl_->close_pair();
  ::close(impl_->wake_fd);
  ::unlink((impl_->link + ".new").c_str());
  ::rmdir(impl_->dir.c_str());
}

std::string ArmControllerSimulator::device_path() const {
  return impl_->link;
}

void ArmControllerSimulator::corrupt_next_replies(int count, std::optional<arm::Command> only_for) {
  std::lock_guard lock(impl_->mutex);
  impl_->corrupt = Injection{count, only_for};
}

void ArmControllerSimulator::drop_next_replies(int count, std::optional<arm::Command> only_for) {
  std::lock_guard lock(impl_->mutex);
  impl_->drop = Injection{count, only_for};
}

void ArmControllerSimulator::garble_next_replies(int count, std::optional<arm::Command> only_for) {
  std::lock_guard lock(impl_->mutex);
  impl_->garble = Injection{count, only_for};
}

void ArmControllerSimulator::set_reply_delay_ms(int ms) {
  std::lock_guard lock(impl_->mutex);
  impl_->settings.reply_delay_ms = ms;
}

void ArmControllerSimulator::set_task_duration_ms(int ms) {
  std::lock_guard lock(impl_->mutex);
  impl_->settings.task_duration_ms = ms;
}

void ArmControllerSimulator::set_refuse_tasks(bool refuse) {
  std::lock_guard lock(impl_->mutex);
  impl_->refuse = refuse;
}

void ArmControllerSimulator::fail_current_task() {
  std::lock_guard lock(impl_->mutex);
  if (impl_->phase == arm::ControllerPhase::kBusy) impl_->fail_task = true;
  impl_->wake();
}

void ArmControllerSimulator::send_raw(std::string bytes) {
  std::lock_guard lock(impl_->mutex);
  impl_->raw_out += bytes;
  impl_->wake();
}

void ArmControllerSimulator::set_fault(ArmSimFault fault) {
  std::lock_guard lock(impl_->mutex);
  impl_->settings.fault = fault;
}

void ArmControllerSimulator::go_silent() {
  std::lock_guard lock(impl_->mutex);
  impl_->fall_silent(Clock::now());
  impl_->wake();
}

void ArmControllerSimulator::answer_again() {
  std::lock_guard lock(impl_->mutex);
  impl_->silent = false;
  impl_->wake();
}

void ArmControllerSimulator::silence_next_stop() {
  std::lock_guard lock(impl_->mutex);
  impl_->silence_next_stop = true;
}

void ArmControllerSimulator::reset_controller() {
  std::lock_guard lock(impl_->mutex);
  impl_->reset_locked();
  impl_->wake();
}

void ArmControllerSimulator::set_ignore_stops(bool ignore) {
  std::lock_guard lock(impl_->mutex);
  impl_->ignore_stops = ignore;
  if (!ignore) impl_->hold_task = false;
}

bool ArmControllerSimulator::silent() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->silent;
}

void ArmControllerSimulator::unplug() {
  impl_->set_plugged(false);
}
void ArmControllerSimulator::replug() {
  impl_->set_plugged(true);
}

ArmControllerSimulator::Counters ArmControllerSimulator::counters() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->counters;
}

arm::ControllerPhase ArmControllerSimulator::phase() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->phase;
}

std::optional<DoorTask> ArmControllerSimulator::last_task() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->task;
}

std::uint32_t ArmControllerSimulator::last_task_id() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->task_id;
}

bool ArmControllerSimulator::plugged() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->plugged;
}

}  // namespace ajar::drivers
