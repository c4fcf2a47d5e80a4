// LoopStatisticsRecorder: the control loop's own timing, told truthfully.
//
// Three quantities per cycle, in nanoseconds:
//   latency   = actual wake-up - the absolute deadline the thread slept to (scheduling latency);
//   execution = end of the cycle's work - wake-up;
//   period    = wake-up - previous wake-up.
// Each goes into an HDR-style log-linear histogram of kSubBuckets buckets per power of two: exact
// below 4.096 us, buckets at most 1 us wide up to 4.19 ms (so every loop rate >= 240 Hz has 1 us
// resolution on all three), 0.05 % relative width above; values >= 2^28 ns (268 ms) share the last
// bucket (reported as the exact maximum since start). A percentile is reported as its bucket's
// midpoint, never above the exact maximum.
//
// Writer: the control thread calls record_cycle() once per cycle (O(1): two relaxed atomic
// increments per quantity, no allocation, no lock) — the histograms ARE the published state,
// updated every cycle. Readers (any other thread; serialised by an internal mutex the control
// thread never takes) compute percentiles on demand, skipping empty powers of two:
//   - "all": since start, or since the last reset(); a reset takes a baseline copy of the counts
//     (reader side), so the control thread is never asked to clear anything;
//   - "recent": the last kWindowNs (10 s) to 12 s, from sparse copies of the counts taken on reads
//     every kWindowNs/5; window_s says exactly how long the recent window is (longer when nobody
//     read the statistics for a while).
// Counts are 32-bit per bucket and wrap after 2^32 samples in ONE bucket (99 days at 500 Hz).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "ajar/protocol/messages.hpp"

namespace ajar::daemon {

// Protocol 1.1's LoopTiming (docs/protocol.md), in ns: window_s, all (since start or the last
// reset), recent (the last window_s seconds).
using TimingQuantiles = protocol::Quantiles;
using TimingSpan = protocol::TimingWindow;
using TimingSummary = protocol::LoopTiming;

class LoopStatisticsRecorder {
 public:
  static constexpr int kSubBucketBits = 11;
  static constexpr std::size_t kSubBuckets = std::size_t{1} << kSubBucketBits;  // 2048
  static constexpr int kMaxValueBits = 28;  // values >= 2^28 ns land in the last bucket
  static constexpr std::size_t kGroups = kMaxValueBits - kSubBucketBits + 1;  // 18
  static constexpr std::size_t kBuckets = kGroups * kSubBuckets;              // 36864
  static constexpr std::int64_t kWindowNs = 10'000'000'000;

  explicit LoopStatisticsRecorder(double rate_hz);
  ~LoopStatisticsRecorder();
  LoopStatisticsRecorder(const LoopStatisticsRecorder&) = delete;
  LoopStatisticsRecorder& operator=(const LoopStatisticsRecorder&) = delete;

  // ---- control thread only ----
  // One cycle: the deadline it slept to, when it woke, when its work ended (CLOCK_MONOTONIC ns).
  void record_cycle(std::int64_t deadline_ns, std::int64_t wake_ns, std::int64_t end_ns) noexcept;
  void record_overrun() noexcept;  // a deadline was missed

  // ---- any thread except the control thread ----
  // Protocol 1.0's summary: cycles, overruns and period percentiles since start or the last reset
  // (one span for all, so overruns / cycles is a ratio); jitter = |period - nominal| p99.
  protocol::LoopStatistics summary() const;
  TimingSummary timing(std::int64_t now_ns) const;
  void reset(std::int64_t now_ns);  // "all" and "recent" restart from now

  std::int64_t nominal_period_ns() const noexcept { return nominal_ns_; }
  // Since start (the reset does not touch them; summary() reports since the reset).
  std::uint64_t cycles() const noexcept { return cycles_.load(std::memory_order_relaxed); }
  std::uint64_t overruns() const noexcept { return overruns_.load(std::memory_order_relaxed); }

  // Bucket arithmetic (exposed for tests).
  static std::size_t bucket_of(std::int64_t value_ns) noexcept;
  static std::int64_t bucket_low(std::size_t bucket) noexcept;    // smallest value in the bucket
  static std::int64_t bucket_width(std::size_t bucket) noexcept;  // number of values in it

 private:
  enum Quantity : std::size_t { kLatency = 0, kExecution = 1, kPeriod = 2, kQuantities = 3 };
  struct Histogram {
    std::array<std::atomic<std::uint32_t>, kBuckets> buckets{};
    std::array<std::atomic<std::uint32_t>, kGroups> groups{};  // sum of each group's buckets
    std::atomic<std::uint32_t> max_ns{0};                      // exact, since start
  };
  // Reader-side copy of the counts at one moment: only the non-zero buckets.
  struct Copy {
    std::int64_t time_ns = 0;
    std::uint64_t overruns = 0;
    std::uint64_t cycles = 0;
    std::array<std::vector<std::pair<std::uint32_t, std::uint32_t>>, kQuantities> buckets;
    std::array<std::array<std::uint32_t, kGroups>, kQuantities> groups{};
  };

  void record(Quantity q, std::int64_t value_ns) noexcept;
  Copy take_copy(std::int64_t now_ns) const;
  void advance_window(std::int64_t now_ns) const;  // reader mutex held
  // Counts of quantity q minus `base` (nullptr: since start), percentiles over them.
  std::uint64_t span_of(Quantity q, const Copy* base, TimingQuantiles& out) const;
  std::uint32_t jitter_p99(const Copy* base) const;

  float rate_hz_;
  std::int64_t nominal_ns_;
  std::unique_ptr<std::array<Histogram, kQuantities>> histograms_;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::int64_t previous_wake_ns_ = -1;  // control thread

  mutable std::mutex reader_mutex_;
  std::unique_ptr<Copy> reset_base_;        // null: since start
  mutable std::deque<Copy> window_copies_;  // oldest first, one every kWindowNs / 5
};

}  // namespace ajar::daemon
