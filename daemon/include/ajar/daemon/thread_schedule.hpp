// A thread's scheduling as the kernel shows it (thread_cpu(): what the loop supervisor reads of
// the control thread), and what the control thread publishes of its own sleep between cycles
// (LoopSleep, read by the supervisor: loop_supervisor.hpp, "the exact wait").
#pragma once

#include <cstdint>

namespace ajar::daemon {

// A thread's scheduling, read from the kernel at one instant.
struct ThreadCpu {
  // Runnable-but-waiting time of the waits that have ended (schedstat run_delay, ns; the kernel
  // adds a wait when it ends, or the part so far when it moves the waiting thread to another
  // CPU: while the thread waits on one CPU this stands still). -1: unknown.
  std::int64_t waited_ns = -1;
  // CPU time used so far (the thread's CPU clock, ns; exact for a thread on a CPU now). -1:
  // unknown.
  std::int64_t on_cpu_ns = -1;
  // Waiting for a CPU at the read: state R (runnable) with no CPU time around the read.
  bool waiting = false;
  // Scheduled SCHED_FIFO or SCHED_RR (control.realtime granted): a wait of such a thread is not
  // the scheduler's ordinary sharing but another realtime thread taking its CPU: not excused.
  bool realtime = false;
  // How many times the kernel gave it a CPU (schedstat's third field, pcount: one more at every
  // switch to it, however short its wait). -1: unknown.
  std::int64_t switch_ins = -1;
};

// The scheduling of the thread `tid` of this process (/proc/self/task/TID/schedstat and stat, the
// thread's CPU clock); unknown fields when tid <= 0 or the kernel does not say. No allocation.
ThreadCpu thread_cpu(int tid) noexcept;

// The thread `tid` of this process (0: the calling thread) is scheduled SCHED_FIFO or SCHED_RR.
bool thread_is_realtime(int tid) noexcept;

// What the control thread publishes of its sleep between two cycles. Just before it sleeps: the
// wake-up it asks for and its own schedstat read then; as soon as it wakes: awake (wake_ns 0).
// From its planned wake-up on a sleeping thread is runnable (give or take the timer's slack, 50 us
// for SCHED_OTHER), so a thread found with this record, past wake_ns, and the switch-ins it had
// when it went to sleep (no CPU since) has waited for a CPU all the time since wake_ns: exactly,
// however late one looks. Of that wait, what run_delay shows already (the kernel moved it to
// another CPU) is run_delay now minus waited_ns. A thread hung in a card call is not in this sleep:
// it woke (awake), or it had a CPU since (switch_ins moved).
// Published through a SeqLock (three words, one writer: the control thread); the reader takes one
// attempt (SeqLock::try_load) and a read that overlapped a store counts as awake: the thread was
// on a CPU then, going to sleep or waking, not waiting in it.
struct LoopSleep {
  std::int64_t wake_ns = 0;      // CLOCK_MONOTONIC ns it asked to wake at; 0: awake (or unknown)
  std::int64_t switch_ins = -1;  // its schedstat switch-ins (pcount) just before it slept
  std::int64_t waited_ns = -1;   // its schedstat run_delay then (ns)
};

// The calling thread's own schedstat through a file it keeps open (/proc/thread-self/schedstat):
// one pread(2) a read, no allocation. Construct it on the thread it is to read (the control
// thread, once, before its first sleep).
class OwnSchedstat {
 public:
  OwnSchedstat() noexcept;
  ~OwnSchedstat();
  OwnSchedstat(const OwnSchedstat&) = delete;
  OwnSchedstat& operator=(const OwnSchedstat&) = delete;

  // The record to publish just before sleeping until `wake_ns`; unknown counters (-1) when the
  // file could not be read.
  LoopSleep going_to_sleep(std::int64_t wake_ns) const noexcept;

 private:
  int fd_ = -1;
};

}  // namespace ajar::daemon
