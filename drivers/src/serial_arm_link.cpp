// One request of SerialManipulator on the wire (serial_arm_impl.hpp): encode, write, wait for the
// reply with its sequence number; retried up to settings.retries times with the SAME number, each
// attempt waiting ack_timeout_ms; a stop waiting (or quit) cuts a request short. Lines that are
// not the awaited reply are counted (bad_lines), except the controller's DONE report.
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "serial_arm_impl.hpp"

namespace ajar::drivers {

using std::chrono::milliseconds;

std::uint16_t SerialManipulator::Impl::take_seq() {
  const std::uint16_t seq = next_seq;
  next_seq = static_cast<std::uint16_t>(next_seq == 65535 ? 1 : next_seq + 1);
  return seq;
}

bool SerialManipulator::Impl::write_all(const std::string& bytes) {
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

bool SerialManipulator::Impl::pump(int timeout_ms) {
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

std::optional<arm::Message> SerialManipulator::Impl::take_lines(std::optional<std::uint16_t> seq) {
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

bool SerialManipulator::Impl::should_preempt(JobKind kind) {
  std::lock_guard lock(mutex);
  // While the link is down the status poll that brings it back must not give way to the stop
  // (which cannot be sent before the link is back).
  const bool link_up = snapshot.phase != ArmPhase::kDisconnected && !link_silent;
  return quit || (kind != JobKind::kStop && stop_pending && link_up);
}

RequestEnd SerialManipulator::Impl::transact(const Job& job, arm::Message& reply) {
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
    return RequestEnd::kReply;  // cannot be encoded (non-finite): treated as refused
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
    if (!write_all(*line)) return RequestEnd::kLinkLost;
    const auto deadline = Clock::now() + milliseconds(settings.ack_timeout_ms);
    for (;;) {
      if (auto r = take_lines(req.seq)) {
        reply = std::move(*r);
        return RequestEnd::kReply;
      }
      if (should_preempt(job.kind)) return RequestEnd::kPreempted;
      const auto left = std::chrono::ceil<milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) break;
      if (!pump(static_cast<int>(left))) return RequestEnd::kLinkLost;
    }
  }
  std::lock_guard lock(mutex);
  ++counters.timeouts;
  return RequestEnd::kTimeout;
}

}  // namespace ajar::drivers
