// A queue of jobs run in order on one thread of its own. The console has two: one for the blocking
// ajar_client calls (connect, Hello, measurements, commands) and one for Stop and EmergencyStop
// only, so a stop never waits behind another request.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

namespace ajar::console {

class Worker {
 public:
  using Job = std::function<void()>;
  // `idle` (may be empty) runs on the worker's thread when no job came for 300 ms.
  explicit Worker(std::function<void()> idle = {});
  ~Worker();  // shutdown()
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  void post(Job job);  // thread-safe
  // Lets the running job finish, drops the queued ones and joins the thread. Idempotent.
  void shutdown();

 private:
  void loop();
  std::function<void()> idle_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> jobs_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace ajar::console
