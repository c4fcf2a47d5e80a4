#include "ajar/drivers/serial_arm.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <termios.h>
#include <unistd.h>

#include <libserial/SerialPort.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstring>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>

#include "ajar/drivers/arm_protocol.hpp"

namespace ajar::drivers {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

std::optional<LibSerial::BaudRate> baud_rate(int baud) {
  using B = LibSerial::BaudRate;
  switch (baud) {
    case 9600:
      return B::BAUD_9600;
    case 19200:
      return B::BAUD_19200;
    case 38400:
      return B::BAUD_38400;
    case 57600:
      return B::BAUD_57600;
    case 115200:
      return B::BAUD_115200;
    case 230400:
      return B::BAUD_230400;
    case 460800:
      return B::BAUD_460800;
    case 921600:
      return B::BAUD_921600;
    default:
      return std::nullopt;
  }
}

std::optional<LibSerial::CharacterSize> char_size(int bits) {
  using C = LibSerial::CharacterSize;
  switch (bits) {
    case 5:
      return C::CHAR_SIZE_5;
    case 6:
      return C::CHAR_SIZE_6;
    case 7:
      return C::CHAR_SIZE_7;
    case 8:
      return C::CHAR_SIZE_8;
    default:
      return std::nullopt;
  }
}

std::optional<LibSerial::Parity> parity(char p) {
  switch (p) {
    case 'N':
      return LibSerial::Parity::PARITY_NONE;
    case 'E':
      return LibSerial::Parity::PARITY_EVEN;
    case 'O':
      return LibSerial::Parity::PARITY_ODD;
    default:
      return std::nullopt;
  }
}

std::optional<LibSerial::StopBits> stop_bits(int bits) {
  switch (bits) {
    case 1:
      return LibSerial::StopBits::STOP_BITS_1;
    case 2:
      return LibSerial::StopBits::STOP_BITS_2;
    default:
      return std::nullopt;
  }
}

// Opens and configures the device with libserial and returns our own descriptor for it.
//
// libserial 1.0's SerialPort::Close() (also run by its destructor) restores the termios saved at
// Open() with tcsetattr() and throws if that fails -- which it does with EIO on a hung-up tty
// (cable pulled, pty master closed), so a SerialPort destroyed after a hang-up terminates the
// process. We therefore keep libserial's descriptor only for opening and configuring: we dup() it,
// take its termios, Close() the SerialPort while the device is healthy, and re-apply the termios on
// our duplicate, which we read with poll()/read() (EIO, hang-up and EOF are visible there).
Result<int> open_configured(const SerialArmSettings& s) {
  const auto baud = baud_rate(s.baud);
  const auto size = char_size(s.data_bits);
  const auto par = parity(s.parity);
  const auto stop = stop_bits(s.stop_bits);
  const std::string where = "serial arm " + s.device + ": ";
  if (!baud) return make_error(ErrorCode::kDriverError, "baud", where + "unsupported baud rate");
  if (!size) return make_error(ErrorCode::kDriverError, "data_bits", where + "data bits not 5..8");
  if (!par) return make_error(ErrorCode::kDriverError, "parity", where + "parity not N, E or O");
  if (!stop) return make_error(ErrorCode::kDriverError, "stop_bits", where + "stop bits not 1/2");

  auto* port = new LibSerial::SerialPort;
  int fd = -1;
  try {
    port->Open(s.device);
    port->SetBaudRate(*baud);
    port->SetCharacterSize(*size);
    port->SetParity(*par);
    port->SetStopBits(*stop);
    port->SetFlowControl(LibSerial::FlowControl::FLOW_CONTROL_NONE);
    fd = ::fcntl(port->GetFileDescriptor(), F_DUPFD_CLOEXEC, 0);
    if (fd < 0) throw std::runtime_error(std::string("dup: ") + std::strerror(errno));
    termios tio{};
    if (::tcgetattr(fd, &tio) != 0) {
      throw std::runtime_error(std::string("tcgetattr: ") + std::strerror(errno));
    }
    port->Close();
    delete port;
    port = nullptr;
    if (::tcsetattr(fd, TCSANOW, &tio) != 0 || ::tcflush(fd, TCIOFLUSH) != 0) {
      throw std::runtime_error(std::string("tcsetattr: ") + std::strerror(errno));
    }
    // O_NONBLOCK (set by libserial's open) is shared by the duplicate: reads never block.
    return fd;
  } catch (const std::exception& e) {
    if (fd >= 0) ::close(fd);
    if (port != nullptr) {
      if (port->IsOpen()) {
        try {
          port->Close();
          delete port;
        } catch (const std::exception&) {
          // Close() failed (hung-up device): close the descriptor ourselves and leak the small
          // SerialPort object, whose destructor would throw again and terminate the process.
          ::close(port->GetFileDescriptor());
        }
      } else {
        delete port;
      }
    }
    return make_error(ErrorCode::kArmDisconnected, "device", where + e.what());
  }
}

enum class JobKind : std::uint8_t { kTask, kStatus, kStop, kClear };

struct Job {
  JobKind kind = JobKind::kStatus;
  std::uint32_t task_id = 0;
  DoorTask task;
};

enum class Outcome : std::uint8_t { kReply, kTimeout, kLinkLost, kPreempted };

}  // namespace

struct SerialManipulator::Impl {
  explicit Impl(SerialArmSettings s) : settings(std::move(s)) {
    std::random_device rd;
    next_seq = static_cast<std::uint16_t>(rd() % 65535U + 1U);
    wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  }
  ~Impl() {
    if (wake_fd >= 0) ::close(wake_fd);
  }

  const SerialArmSettings settings;
  int wake_fd = -1;

  // Shared between the caller threads and the worker.
  mutable std::mutex mutex;
  ArmStatus snapshot;
  Counters counters;
  bool running = false;
  bool quit = false;
  bool stop_pending = false;
  bool clear_pending = false;
  std::optional<Job> task_pending;
  std::uint32_t next_task_id = 1;
  ErrorCode latched = ErrorCode::kOk;  // host-side fault (timeout, rejected, lost) until cleared
  std::uint32_t unconfirmed_task = 0;  // task sent but not acknowledged when the link was lost
  bool link_silent = false;            // the controller stopped answering the status poll

  // Worker-only (or the connecting thread before the worker starts).
  int fd = -1;
  arm::LineReader reader;
  std::uint16_t next_seq = 1;
  std::thread worker;

  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(wake_fd, &one, sizeof one);
  }

  void drain_wake() const {
    std::uint64_t count = 0;
    [[maybe_unused]] const auto n = ::read(wake_fd, &count, sizeof count);
  }

  std::uint16_t take_seq() {
    const std::uint16_t seq = next_seq;
    next_seq = static_cast<std::uint16_t>(next_seq == 65535 ? 1 : next_seq + 1);
    return seq;
  }

  void close_fd() {
    if (fd >= 0) ::close(fd);
    fd = -1;
    reader.clear();
  }

  // --- snapshot updates (mutex held) ---
  void apply_controller_locked(arm::ControllerPhase phase, std::uint32_t task_id) {
    if (task_pending) return;  // a newer task is queued: keep showing it (busy, its id)
    if (task_id != 0) snapshot.task_id = task_id;
    if (latched != ErrorCode::kOk) {
      snapshot.phase = ArmPhase::kFault;
      snapshot.last_error = latched;
      return;
    }
    switch (phase) {
      case arm::ControllerPhase::kIdle:
        snapshot.phase = ArmPhase::kIdle;
        snapshot.last_error = ErrorCode::kOk;
        break;
      case arm::ControllerPhase::kBusy:
        snapshot.phase = ArmPhase::kBusy;
        snapshot.last_error = ErrorCode::kOk;
        break;
      case arm::ControllerPhase::kDone:
        snapshot.phase = ArmPhase::kDone;
        snapshot.last_error = ErrorCode::kOk;
        break;
      case arm::ControllerPhase::kFault:
        snapshot.phase = ArmPhase::kFault;
        snapshot.last_error = ErrorCode::kArmFault;
        break;
    }
  }

  void link_lost_locked(ErrorCode why) {
    snapshot.phase = ArmPhase::kDisconnected;
    snapshot.last_error = why;
  }

  // A reply or report arrived after a link loss or silence: count the reconnect, reconcile a task
  // whose acknowledgement was lost with the link.
  void link_back_locked(arm::ControllerPhase phase, std::uint32_t task_id) {
    if (snapshot.phase == ArmPhase::kDisconnected || link_silent) {
      ++snapshot.reconnects;
      link_silent = false;
    }
    if (unconfirmed_task != 0) {
      if (task_id != unconfirmed_task) latched = ErrorCode::kArmDisconnected;
      unconfirmed_task = 0;
    }
    if (snapshot.phase == ArmPhase::kDisconnected) {
      snapshot.phase = task_pending ? ArmPhase::kBusy : ArmPhase::kIdle;
      snapshot.last_error = ErrorCode::kOk;
    }
    apply_controller_locked(phase, task_id);
  }

  // --- I/O (worker thread, no lock held) ---
  bool write_all(const std::string& bytes) {
    std::size_t off = 0;
    const auto deadline = Clock::now() + milliseconds(settings.ack_timeout_ms);
    while (off < bytes.size()) {
      const auto n = ::write(fd, bytes.data() + off, bytes.size() - off);
      if (n > 0) {
        off += static_cast<std::size_t>(n);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && Clock::now() < deadline) {
        pollfd p{fd, POLLOUT, 0};
        ::poll(&p, 1, 10);
        continue;
      }
      return false;  // EIO, ENODEV, ... or the output never drained
    }
    return true;
  }

  // Waits up to `timeout_ms` for bytes or a wake-up; feeds the reader. False when the link is lost.
  bool pump(int timeout_ms) {
    pollfd fds[2] = {{wake_fd, POLLIN, 0}, {fd, POLLIN, 0}};
    const int r = ::poll(fds, 2, std::max(timeout_ms, 0));
    if (r < 0) return errno == EINTR;
    if ((fds[0].revents & POLLIN) != 0) drain_wake();
    if ((fds[1].revents & POLLNVAL) != 0) return false;
    if ((fds[1].revents & (POLLIN | POLLHUP | POLLERR)) == 0) return true;
    char buf[512];
    const auto n = ::read(fd, buf, sizeof buf);
    if (n > 0) {
      reader.feed(std::string_view(buf, static_cast<std::size_t>(n)));
      std::lock_guard lock(mutex);
      counters.dropped_bytes = reader.dropped_bytes();
      return true;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return (fds[1].revents & POLLHUP) == 0;
    return false;  // 0 = hang-up (EOF on a tty), or EIO / ENODEV
  }

  // Handles complete lines; returns the reply with sequence number `seq` if one came.
  std::optional<arm::Message> take_lines(std::optional<std::uint16_t> seq) {
    std::optional<arm::Message> reply;
    while (auto line = reader.next_line()) {
      auto m = arm::decode(*line);
      std::lock_guard lock(mutex);
      if (!m) {
        ++counters.bad_lines;
        continue;
      }
      if (m->seq == arm::kUnsolicitedSeq && m->command == arm::Command::kDone) {
        if (m->task_id == snapshot.task_id && snapshot.phase == ArmPhase::kBusy && !task_pending &&
            latched == ErrorCode::kOk) {
          snapshot.phase = ArmPhase::kDone;
        }
        continue;
      }
      const bool is_reply = m->command == arm::Command::kAck || m->command == arm::Command::kNak ||
                            m->command == arm::Command::kReport;
      if (is_reply && seq && m->seq == *seq && !reply) {
        reply = std::move(m).value();
      } else {
        ++counters.bad_lines;  // stale reply (an earlier request's replay) or unexpected message
      }
    }
    return reply;
  }

  bool should_preempt(JobKind kind) {
    std::lock_guard lock(mutex);
    // While the link is down the status poll that brings it back must not give way to the stop
    // (which cannot be sent before the link is back).
    const bool link_up = snapshot.phase != ArmPhase::kDisconnected && !link_silent;
    return quit || (kind != JobKind::kStop && stop_pending && link_up);
  }

  // One request: the same sequence number on every attempt.
  Outcome transact(const Job& job, arm::Message& reply) {
    arm::Message req;
    req.seq = take_seq();
    switch (job.kind) {
      case JobKind::kTask:
        req.command = arm::Command::kTask;
        req.task_id = job.task_id;
        req.task = job.task;
        break;
      case JobKind::kStatus:
        req.command = arm::Command::kStatus;
        break;
      case JobKind::kStop:
        req.command = arm::Command::kStop;
        break;
      case JobKind::kClear:
        req.command = arm::Command::kClear;
        break;
    }
    auto line = arm::encode(req);
    if (!line) {
      reply.command = arm::Command::kNak;
      reply.reason = arm::RejectReason::kBadRequest;
      return Outcome::kReply;  // cannot be encoded (non-finite): treated as refused
    }
    {
      std::lock_guard lock(mutex);
      ++counters.requests;
    }
    for (int attempt = 0; attempt <= std::max(settings.retries, 0); ++attempt) {
      if (attempt > 0) {
        std::lock_guard lock(mutex);
        ++counters.retransmissions;
      }
      if (!write_all(*line)) return Outcome::kLinkLost;
      const auto deadline = Clock::now() + milliseconds(settings.ack_timeout_ms);
      for (;;) {
        if (auto r = take_lines(req.seq)) {
          reply = std::move(*r);
          return Outcome::kReply;
        }
        if (should_preempt(job.kind)) return Outcome::kPreempted;
        const auto left = std::chrono::ceil<milliseconds>(deadline - Clock::now()).count();
        if (left <= 0) break;
        if (!pump(static_cast<int>(left))) return Outcome::kLinkLost;
      }
    }
    std::lock_guard lock(mutex);
    ++counters.timeouts;
    return Outcome::kTimeout;
  }

  void on_link_lost() {
    close_fd();
    std::lock_guard lock(mutex);
    link_lost_locked(ErrorCode::kArmDisconnected);
  }

  void run_job(const Job& job) {
    arm::Message reply;
    const Outcome outcome = transact(job, reply);
    if (outcome == Outcome::kLinkLost) {
      if (job.kind == JobKind::kTask) {
        std::lock_guard lock(mutex);
        unconfirmed_task = job.task_id;
      }
      if (job.kind == JobKind::kStop) {
        std::lock_guard lock(mutex);
        stop_pending = true;  // send it again on reconnect
      }
      on_link_lost();
      return;
    }
    std::lock_guard lock(mutex);
    switch (outcome) {
      case Outcome::kPreempted:
        return;  // a stop follows (or we are quitting); the stop's reply sets the phase
      case Outcome::kTimeout:
        if (job.kind == JobKind::kTask) {
          latched = ErrorCode::kArmTimeout;
          snapshot.phase = ArmPhase::kFault;
          snapshot.last_error = latched;
        } else {
          // The controller is silent: only the status poll runs until it answers again; an
          // unanswered stop goes out again then.
          link_silent = true;
          link_lost_locked(ErrorCode::kArmTimeout);
          if (job.kind == JobKind::kStop) stop_pending = true;
        }
        return;
      case Outcome::kReply:
      case Outcome::kLinkLost:
        break;
    }
    if (job.kind == JobKind::kClear && reply.command == arm::Command::kAck) {
      latched = ErrorCode::kOk;
    }
    if (job.kind == JobKind::kTask && reply.command == arm::Command::kNak) {
      latched = ErrorCode::kArmRejected;
    }
    link_back_locked(reply.phase, reply.task_id);
  }

  std::optional<Job> next_job(Clock::time_point& next_poll) {
    std::lock_guard lock(mutex);
    const bool link_up = snapshot.phase != ArmPhase::kDisconnected && !link_silent;
    if (!link_up) {
      // Only the status poll runs until the controller answers; it reconciles and brings the
      // link back, then queued work goes out.
      if (Clock::now() < next_poll) return std::nullopt;
      next_poll = Clock::now() + milliseconds(kStatusPollMs);
      return Job{JobKind::kStatus, 0, {}};
    }
    if (stop_pending) {
      stop_pending = false;
      return Job{JobKind::kStop, 0, {}};
    }
    if (clear_pending) {
      clear_pending = false;
      return Job{JobKind::kClear, 0, {}};
    }
    if (task_pending) {
      Job job = *task_pending;
      task_pending.reset();
      return job;
    }
    if (Clock::now() >= next_poll) {
      next_poll = Clock::now() + milliseconds(kStatusPollMs);
      return Job{JobKind::kStatus, 0, {}};
    }
    return std::nullopt;
  }

  void run() {
    int backoff_ms = std::max(settings.reconnect_min_ms, 1);
    auto next_poll = Clock::now() + milliseconds(kStatusPollMs);
    for (;;) {
      {
        std::lock_guard lock(mutex);
        if (quit) break;
      }
      if (fd < 0) {
        pollfd p{wake_fd, POLLIN, 0};
        ::poll(&p, 1, backoff_ms);
        drain_wake();
        {
          std::lock_guard lock(mutex);
          if (quit) break;
        }
        auto opened = open_configured(settings);
        if (!opened) {
          backoff_ms = std::min(backoff_ms * 2, std::max(settings.reconnect_max_ms, 1));
          continue;
        }
        fd = opened.value();
        backoff_ms = std::max(settings.reconnect_min_ms, 1);
        next_poll = Clock::now();  // the status report reconciles and marks the link back
        continue;
      }
      if (auto job = next_job(next_poll)) {
        run_job(*job);
        continue;
      }
      const auto left = std::chrono::ceil<milliseconds>(next_poll - Clock::now()).count();
      if (!pump(static_cast<int>(std::max<std::int64_t>(left, 0)))) {
        on_link_lost();
        continue;
      }
      take_lines(std::nullopt);
    }
  }
};

SerialManipulator::SerialManipulator(SerialArmSettings settings)
    : impl_(std::make_unique<Impl>(std::move(settings))) {}

SerialManipulator::~SerialManipulator() {
  (void)disconnect();
}

ajar::Outcome SerialManipulator::connect() {
  {
    std::lock_guard lock(impl_->mutex);
    if (impl_->running) return Ok{};
    impl_->quit = false;
  }
  if (impl_->wake_fd < 0) {
    return make_error(ErrorCode::kDriverError, "", "serial arm: eventfd failed");
  }
  auto opened = open_configured(impl_->settings);
  if (!opened) return std::move(opened).error();
  impl_->fd = opened.value();
  arm::Message reply;
  const Outcome outcome = impl_->transact(Job{JobKind::kStatus, 0, {}}, reply);
  if (outcome != Outcome::kReply) {
    impl_->close_fd();
    const bool lost = outcome == Outcome::kLinkLost;
    return make_error(lost ? ErrorCode::kArmDisconnected : ErrorCode::kArmTimeout, "device",
                      "serial arm " + impl_->settings.device +
                          (lost ? ": link lost while connecting"
                                : ": the arm controller did not answer the status query"));
  }
  {
    std::lock_guard lock(impl_->mutex);
    impl_->running = true;
    impl_->snapshot.phase = ArmPhase::kIdle;
    impl_->snapshot.last_error = ErrorCode::kOk;
    impl_->apply_controller_locked(reply.phase, reply.task_id);
  }
  impl_->worker = std::thread([impl = impl_.get()] { impl->run(); });
  return Ok{};
}

ajar::Outcome SerialManipulator::disconnect() {
  {
    std::lock_guard lock(impl_->mutex);
    if (!impl_->running) return Ok{};
    impl_->quit = true;
  }
  impl_->wake();
  impl_->worker.join();
  impl_->close_fd();
  std::lock_guard lock(impl_->mutex);
  impl_->running = false;
  impl_->stop_pending = false;
  impl_->clear_pending = false;
  impl_->task_pending.reset();
  impl_->snapshot.phase = ArmPhase::kDisconnected;
  impl_->snapshot.last_error = ErrorCode::kOk;
  return Ok{};
}

Result<std::uint32_t> SerialManipulator::hand_off(const DoorTask& task) {
  if (!task.contact_base_m.allFinite() || !std::isfinite(task.door_width_m) ||
      !std::isfinite(task.handle_length_m)) {
    return make_error(ErrorCode::kNonFinite, "task", "serial arm: non-finite task field");
  }
  std::lock_guard lock(impl_->mutex);
  auto& s = impl_->snapshot;
  if (!impl_->running || s.phase == ArmPhase::kDisconnected) {
    return make_error(ErrorCode::kArmDisconnected, "",
                      "serial arm " + impl_->settings.device + ": not connected");
  }
  if (impl_->task_pending || s.phase == ArmPhase::kBusy) {
    return make_error(ErrorCode::kWrongState, "", "serial arm: a task is busy");
  }
  if (s.phase == ArmPhase::kFault) {
    return make_error(ErrorCode::kWrongState, "", "serial arm: faulted; clear_fault first");
  }
  const std::uint32_t id = impl_->next_task_id++;
  impl_->task_pending = Job{JobKind::kTask, id, task};
  s.phase = ArmPhase::kBusy;
  s.task_id = id;
  s.last_error = ErrorCode::kOk;
  impl_->wake();
  return id;
}

ajar::Outcome SerialManipulator::stop() {
  std::lock_guard lock(impl_->mutex);
  auto& s = impl_->snapshot;
  if (impl_->task_pending) {  // never sent: cancel it here
    impl_->task_pending.reset();
    if (s.phase == ArmPhase::kBusy) s.phase = ArmPhase::kIdle;
  }
  if (!impl_->running) {
    return make_error(ErrorCode::kArmDisconnected, "", "serial arm: not connected");
  }
  impl_->stop_pending = true;
  impl_->wake();
  if (s.phase == ArmPhase::kDisconnected) {
    return make_error(
        ErrorCode::kArmDisconnected, "",
        "serial arm " + impl_->settings.device + ": link down; the stop is sent when it returns");
  }
  return Ok{};
}

ajar::Outcome SerialManipulator::clear_fault() {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->running || impl_->snapshot.phase == ArmPhase::kDisconnected) {
    return make_error(ErrorCode::kArmDisconnected, "",
                      "serial arm " + impl_->settings.device + ": not connected");
  }
  if (impl_->snapshot.phase != ArmPhase::kFault) return Ok{};  // nothing to clear
  impl_->clear_pending = true;
  impl_->wake();
  return Ok{};
}

ArmStatus SerialManipulator::status() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->snapshot;
}

SerialManipulator::Counters SerialManipulator::counters() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->counters;
}

}  // namespace ajar::drivers
