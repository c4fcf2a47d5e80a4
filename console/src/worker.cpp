#include "worker.hpp"

#include <chrono>
#include <utility>

namespace ajar::console {

Worker::Worker(std::function<void()> idle) : idle_(std::move(idle)) {
  thread_ = std::thread([this] { loop(); });
}

Worker::~Worker() {
  shutdown();
}

void Worker::post(Job job) {
  {
    const std::lock_guard lock(mutex_);
    jobs_.push_back(std::move(job));
  }
  cv_.notify_one();
}

void Worker::shutdown() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_one();
  if (thread_.joinable()) thread_.join();
}

void Worker::loop() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (jobs_.empty()) {
      cv_.wait_for(lock, std::chrono::milliseconds(300));
      if (jobs_.empty()) {
        if (idle_ && !stopping_) {
          lock.unlock();
          idle_();
          lock.lock();
        }
        continue;
      }
    }
    Job job = std::move(jobs_.front());
    jobs_.pop_front();
    lock.unlock();
    job();
    lock.lock();
  }
}

}  // namespace ajar::console
