// Realtime set-up: what the control thread got is read back from the kernel and described in the
// start-up log line; locking memory shrinks the default thread stack first.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>

#include <thread>

#include "ajar/daemon/realtime.hpp"

namespace ajar::daemon {
namespace {

TEST(Realtime, NothingRequestedIsReportedAsSuch) {
  std::vector<std::string> warnings;
  RealtimeGranted granted;
  std::thread([&] {
    warnings = apply_realtime({});
    granted = realtime_granted();
  }).join();
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(granted.policy, SCHED_OTHER);
  EXPECT_FALSE(granted.memory_locked);
  const std::string line = describe_realtime({}, granted);
  EXPECT_NE(line.find("control thread SCHED_OTHER (control.realtime: false)"), std::string::npos)
      << line;
  EXPECT_NE(line.find("memory not locked (control.lock_memory: false)"), std::string::npos) << line;
}

TEST(Realtime, FifoIsReadBackFromTheKernelOrRefusedWithAWarning) {
  RealtimeRequest request;
  request.realtime = true;
  request.priority = 10;
  std::vector<std::string> warnings;
  RealtimeGranted granted;
  std::thread([&] {
    warnings = apply_realtime(request);
    granted = realtime_granted();
  }).join();
  const std::string line = describe_realtime(request, granted);
  if (warnings.empty()) {
    EXPECT_EQ(granted.policy, SCHED_FIFO);
    EXPECT_EQ(granted.priority, 10);
    EXPECT_NE(line.find("SCHED_FIFO priority 10"), std::string::npos) << line;
  } else {
    EXPECT_EQ(granted.policy, SCHED_OTHER);
    EXPECT_NE(warnings.front().find("control.realtime"), std::string::npos);
    EXPECT_NE(line.find("SCHED_OTHER (SCHED_FIFO refused)"), std::string::npos) << line;
  }
}

std::size_t new_thread_stack_bytes() {
  std::size_t size = 0;
  std::thread([&] {
    pthread_attr_t attr;
    pthread_getattr_np(pthread_self(), &attr);
    pthread_attr_getstacksize(&attr, &size);
    pthread_attr_destroy(&attr);
  }).join();
  return size;
}

TEST(Realtime, LockingMemoryShrinksTheDefaultThreadStackFirst) {
  pthread_attr_t saved;
  ASSERT_EQ(pthread_getattr_default_np(&saved), 0);
  prepare_process({});  // nothing to lock: no change
  const std::size_t before = new_thread_stack_bytes();
  RealtimeRequest lock;
  lock.lock_memory = true;
  prepare_process(lock);
  const std::size_t after = new_thread_stack_bytes();
  pthread_setattr_default_np(&saved);
  pthread_attr_destroy(&saved);
  EXPECT_LE(after, kLockedThreadStackBytes);
  if (before > kLockedThreadStackBytes) {
    EXPECT_LT(after, before);
  }
}

}  // namespace
}  // namespace ajar::daemon
