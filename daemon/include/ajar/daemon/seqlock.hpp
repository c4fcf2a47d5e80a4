// SeqLock<T>: one writer publishes a trivially copyable value; any number of readers take
// consistent copies without locks. The writer never waits; a reader retries while a write is in
// progress. The value is stored as atomic words (not plain memory) so that the reader's
// speculative copy is not a data race (ThreadSanitizer-clean by construction).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace ajar::daemon {

template <typename T>
class SeqLock {
  static_assert(std::is_trivially_copyable_v<T>);
  static constexpr std::size_t kWords =
      (sizeof(T) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);

 public:
  SeqLock() { store(T{}); }

  // Writer only (one thread). Wait-free, no allocation.
  void store(const T& value) noexcept {
    std::array<std::uint64_t, kWords> buffer{};
    std::memcpy(buffer.data(), &value, sizeof(T));
    const std::uint64_t seq = sequence_.load(std::memory_order_relaxed);
    sequence_.store(seq + 1, std::memory_order_relaxed);
    // Release on every word, no fences (GCC TSan does not support atomic_thread_fence): a reader
    // that sees any new word also sees the odd sequence stored before it, and retries.
    for (std::size_t i = 0; i < kWords; ++i)
      words_[i].store(buffer[i], std::memory_order_release);
    sequence_.store(seq + 2, std::memory_order_release);
  }

  // Any thread. Retries while the writer is in the middle of a store.
  T load() const noexcept {
    T value;
    while (!try_load(value)) {
    }
    return value;
  }

  // Any thread, one attempt: never waits for the writer (a reader that must not spin behind a
  // writer it may be keeping off its CPU). False, `value` untouched, when a store overlapped it.
  bool try_load(T& value) const noexcept {
    std::array<std::uint64_t, kWords> buffer{};
    const std::uint64_t before = sequence_.load(std::memory_order_acquire);
    if ((before & 1U) != 0) return false;
    for (std::size_t i = 0; i < kWords; ++i)
      buffer[i] = words_[i].load(std::memory_order_acquire);
    if (sequence_.load(std::memory_order_relaxed) != before) return false;
    std::memcpy(static_cast<void*>(&value), buffer.data(), sizeof(T));
    return true;
  }

 private:
  std::atomic<std::uint64_t> sequence_{0};
  std::array<std::atomic<std::uint64_t>, kWords> words_{};
};

}  // namespace ajar::daemon
