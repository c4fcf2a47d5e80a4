// SpscRing<T, N>: a bounded single-producer single-consumer ring of fixed-size records for the
// control loop's side of the recorder. push() is wait-free: no allocation, no lock, no system call
// (two atomic loads, a copy, one release store); a full ring drops the record and counts it
// (dropped()), never blocking the producer. pop() is the consumer's (the recorder thread).
// N must be a power of two; T trivially copyable. Indices are free-running 64-bit counters.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace ajar::recorder {

template <typename T, std::size_t N>
class SpscRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "capacity must be a power of two");
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  static constexpr std::size_t kCapacity = N;

  // Producer only. False (and counted) when the ring is full.
  bool push(const T& item) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= N) {
      dropped_.store(dropped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      return false;
    }
    slots_[head & (N - 1)] = item;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer only. False when empty.
  bool pop(T& item) noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    item = slots_[tail & (N - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Any thread.
  std::uint64_t pushed() const noexcept { return head_.load(std::memory_order_relaxed); }
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  alignas(64) std::atomic<std::uint64_t> head_{0};  // written by the producer
  alignas(64) std::atomic<std::uint64_t> tail_{0};  // written by the consumer
  alignas(64) std::atomic<std::uint64_t> dropped_{0};
  T slots_[N];
};

}  // namespace ajar::recorder
