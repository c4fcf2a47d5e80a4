// Polls `condition` (every 5 ms) until it holds or the bound passes: the tests' one wait for
// something another thread or process does. Never asserts timing, only eventual truth: the bound
// is generous (20 s) and a condition that holds ends the wait at once.
#pragma once

#include <chrono>
#include <thread>

namespace ajar::test {

template <typename Condition>
bool eventually(Condition condition, std::chrono::milliseconds bound = std::chrono::seconds(20)) {
  const auto deadline = std::chrono::steady_clock::now() + bound;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return condition();
}

}  // namespace ajar::test
