// LoopStatisticsRecorder: the control loop's own timing, measured without allocation. Periods
// (wake-up to wake-up) go into a fixed histogram of kBins bins, each nominal/kBinsPerPeriod wide,
// covering 0..4x the nominal period (longer periods land in the last bin; the maximum is kept
// exactly). Percentiles are cumulative since start, read from the histogram (resolution: one bin,
// reported as the bin's upper edge). Jitter is |period - nominal| in its own histogram.
// Single-threaded: the control loop records, and copies summary() into its published snapshot.
#pragma once

#include <array>
#include <cstdint>

#include "ajar/protocol/messages.hpp"

namespace ajar::daemon {

class LoopStatisticsRecorder {
 public:
  static constexpr std::size_t kBinsPerPeriod = 256;
  static constexpr std::size_t kBins = 4 * kBinsPerPeriod;

  explicit LoopStatisticsRecorder(double rate_hz) noexcept;

  void record_period(std::int64_t period_ns) noexcept;  // one completed cycle
  void record_overrun() noexcept;                       // a deadline was missed
  protocol::LoopStatistics summary() const noexcept;    // O(kBins)

  std::int64_t nominal_period_ns() const noexcept { return nominal_ns_; }
  std::uint64_t overruns() const noexcept { return overruns_; }

 private:
  static std::uint32_t percentile(const std::array<std::uint32_t, kBins>& histogram,
                                  std::uint64_t count, double fraction, std::int64_t bin_ns,
                                  std::uint32_t max_ns) noexcept;

  float rate_hz_;
  std::int64_t nominal_ns_;
  std::int64_t bin_ns_;
  std::uint64_t cycles_ = 0;
  std::uint64_t periods_ = 0;
  std::uint64_t overruns_ = 0;
  std::uint32_t max_period_ns_ = 0;
  std::uint32_t max_jitter_ns_ = 0;
  std::array<std::uint32_t, kBins> period_histogram_{};
  std::array<std::uint32_t, kBins> jitter_histogram_{};
};

}  // namespace ajar::daemon
