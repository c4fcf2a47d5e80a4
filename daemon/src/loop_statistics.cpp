#include "ajar/daemon/loop_statistics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ajar::daemon {
namespace {

std::uint32_t clamp_u32(std::int64_t v) noexcept {
  return static_cast<std::uint32_t>(
      std::clamp<std::int64_t>(v, 0, std::numeric_limits<std::uint32_t>::max()));
}

}  // namespace

LoopStatisticsRecorder::LoopStatisticsRecorder(double rate_hz) noexcept
    : rate_hz_(static_cast<float>(rate_hz)),
      nominal_ns_(std::max<std::int64_t>(1, std::llround(1e9 / std::max(rate_hz, 1e-3)))),
      bin_ns_(std::max<std::int64_t>(1, nominal_ns_ / static_cast<std::int64_t>(kBinsPerPeriod))) {}

void LoopStatisticsRecorder::record_period(std::int64_t period_ns) noexcept {
  ++cycles_;
  if (period_ns < 0) return;
  ++periods_;
  const auto bin = [this](std::int64_t ns) {
    return static_cast<std::size_t>(std::min<std::int64_t>(ns / bin_ns_, kBins - 1));
  };
  const std::int64_t jitter =
      period_ns > nominal_ns_ ? period_ns - nominal_ns_ : nominal_ns_ - period_ns;
  ++period_histogram_[bin(period_ns)];
  ++jitter_histogram_[bin(jitter)];
  max_period_ns_ = std::max(max_period_ns_, clamp_u32(period_ns));
  max_jitter_ns_ = std::max(max_jitter_ns_, clamp_u32(jitter));
}

void LoopStatisticsRecorder::record_overrun() noexcept {
  ++overruns_;
}

std::uint32_t LoopStatisticsRecorder::percentile(const std::array<std::uint32_t, kBins>& histogram,
                                                 std::uint64_t count, double fraction,
                                                 std::int64_t bin_ns,
                                                 std::uint32_t max_ns) noexcept {
  if (count == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(fraction * static_cast<double>(count)));
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    seen += histogram[i];
    if (seen >= rank) {
      if (i == kBins - 1) return max_ns;  // the overflow bin: all we know exactly is the maximum
      return std::min(max_ns, clamp_u32(static_cast<std::int64_t>(i + 1) * bin_ns));
    }
  }
  return max_ns;
}

protocol::LoopStatistics LoopStatisticsRecorder::summary() const noexcept {
  protocol::LoopStatistics s;
  s.rate_hz = rate_hz_;
  s.cycles = cycles_;
  s.overruns = overruns_;
  s.period_p50_ns = percentile(period_histogram_, periods_, 0.50, bin_ns_, max_period_ns_);
  s.period_p99_ns = percentile(period_histogram_, periods_, 0.99, bin_ns_, max_period_ns_);
  s.period_max_ns = max_period_ns_;
  s.jitter_p99_ns = percentile(jitter_histogram_, periods_, 0.99, bin_ns_, max_jitter_ns_);
  return s;
}

}  // namespace ajar::daemon
