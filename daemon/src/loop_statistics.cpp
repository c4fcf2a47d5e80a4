#include "ajar/daemon/loop_statistics.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace ajar::daemon {
namespace {

constexpr auto kRelaxed = std::memory_order_relaxed;
constexpr std::int64_t kCopyIntervalNs = LoopStatisticsRecorder::kWindowNs / 5;

std::uint32_t clamp_u32(std::int64_t v) noexcept {
  return static_cast<std::uint32_t>(
      std::clamp<std::int64_t>(v, 0, std::numeric_limits<std::uint32_t>::max()));
}

// Count in a sparse copy (sorted by bucket) at `bucket`, walking forward with `cursor`.
std::uint32_t base_count(const std::vector<std::pair<std::uint32_t, std::uint32_t>>* base,
                         std::size_t& cursor, std::size_t bucket) noexcept {
  if (base == nullptr) return 0;
  while (cursor < base->size() && (*base)[cursor].first < bucket)
    ++cursor;
  return cursor < base->size() && (*base)[cursor].first == bucket ? (*base)[cursor].second : 0;
}

}  // namespace

std::size_t LoopStatisticsRecorder::bucket_of(std::int64_t value_ns) noexcept {
  const auto v = static_cast<std::uint64_t>(
      std::clamp<std::int64_t>(value_ns, 0, (std::int64_t{1} << kMaxValueBits) - 1));
  if (v < 2 * kSubBuckets) return static_cast<std::size_t>(v);
  const int shift = static_cast<int>(std::bit_width(v)) - 1 - kSubBucketBits;  // >= 1
  return static_cast<std::size_t>(shift) * kSubBuckets + static_cast<std::size_t>(v >> shift);
}

std::int64_t LoopStatisticsRecorder::bucket_low(std::size_t bucket) noexcept {
  if (bucket < 2 * kSubBuckets) return static_cast<std::int64_t>(bucket);
  const std::size_t shift = bucket / kSubBuckets - 1;
  return static_cast<std::int64_t>(bucket - shift * kSubBuckets) << shift;
}

std::int64_t LoopStatisticsRecorder::bucket_width(std::size_t bucket) noexcept {
  if (bucket < 2 * kSubBuckets) return 1;
  return std::int64_t{1} << (bucket / kSubBuckets - 1);
}

LoopStatisticsRecorder::LoopStatisticsRecorder(double rate_hz)
    : rate_hz_(static_cast<float>(rate_hz)),
      nominal_ns_(std::max<std::int64_t>(1, std::llround(1e9 / std::max(rate_hz, 1e-3)))),
      histograms_(std::make_unique<std::array<Histogram, kQuantities>>()) {}

LoopStatisticsRecorder::~LoopStatisticsRecorder() = default;

void LoopStatisticsRecorder::record(Quantity q, std::int64_t value_ns) noexcept {
  Histogram& h = (*histograms_)[q];
  const std::size_t b = bucket_of(value_ns);
  // Single writer: plain load + store (no locked instruction); readers load relaxed.
  h.buckets[b].store(h.buckets[b].load(kRelaxed) + 1, kRelaxed);
  auto& group = h.groups[b / kSubBuckets];
  group.store(group.load(kRelaxed) + 1, kRelaxed);
  const std::uint32_t v = clamp_u32(value_ns);
  if (v > h.max_ns.load(kRelaxed)) h.max_ns.store(v, kRelaxed);
}

void LoopStatisticsRecorder::record_cycle(std::int64_t deadline_ns, std::int64_t wake_ns,
                                          std::int64_t end_ns) noexcept {
  record(kLatency, wake_ns - deadline_ns);
  record(kExecution, end_ns - wake_ns);
  if (previous_wake_ns_ >= 0) record(kPeriod, wake_ns - previous_wake_ns_);
  previous_wake_ns_ = wake_ns;
  cycles_.store(cycles_.load(kRelaxed) + 1, kRelaxed);
}

void LoopStatisticsRecorder::record_overrun() noexcept {
  overruns_.store(overruns_.load(kRelaxed) + 1, kRelaxed);
}

LoopStatisticsRecorder::Copy LoopStatisticsRecorder::take_copy(std::int64_t now_ns) const {
  Copy c;
  c.time_ns = now_ns;
  c.overruns = overruns();
  c.cycles = cycles();
  for (std::size_t q = 0; q < kQuantities; ++q) {
    const Histogram& h = (*histograms_)[q];
    for (std::size_t g = 0; g < kGroups; ++g) {
      c.groups[q][g] = h.groups[g].load(kRelaxed);
      if (c.groups[q][g] == 0) continue;  // counts only grow: an empty group has empty buckets
      for (std::size_t b = g * kSubBuckets; b < (g + 1) * kSubBuckets; ++b)
        if (const std::uint32_t n = h.buckets[b].load(kRelaxed); n != 0)
          c.buckets[q].emplace_back(static_cast<std::uint32_t>(b), n);
    }
  }
  return c;
}

std::uint64_t LoopStatisticsRecorder::span_of(Quantity q, const Copy* base,
                                              TimingQuantiles& out) const {
  const Histogram& h = (*histograms_)[q];
  std::array<std::uint32_t, kGroups> groups{};
  std::uint64_t total = 0;
  for (std::size_t g = 0; g < kGroups; ++g) {
    groups[g] = h.groups[g].load(kRelaxed) - (base != nullptr ? base->groups[q][g] : 0);
    total += groups[g];
  }
  out = TimingQuantiles{};
  if (total == 0) return 0;
  const std::uint32_t exact_max = h.max_ns.load(kRelaxed);
  const double fractions[3] = {0.50, 0.99, 0.999};
  std::uint32_t* targets[3] = {&out.p50_ns, &out.p99_ns, &out.p999_ns};
  std::uint64_t ranks[3];
  for (int i = 0; i < 3; ++i)
    ranks[i] = std::max<std::uint64_t>(
        1, static_cast<std::uint64_t>(std::ceil(fractions[i] * static_cast<double>(total))));
  const auto value_of = [&](std::size_t b) {
    return std::min(exact_max, clamp_u32(bucket_low(b) + (bucket_width(b) - 1) / 2));
  };
  const auto* sparse = base != nullptr ? &base->buckets[q] : nullptr;
  std::size_t cursor = 0;
  std::uint64_t seen = 0;
  int next = 0;
  std::size_t highest = 0;
  for (std::size_t g = 0; g < kGroups; ++g) {
    if (groups[g] == 0) continue;
    for (std::size_t b = g * kSubBuckets; b < (g + 1) * kSubBuckets; ++b) {
      const std::uint32_t n = h.buckets[b].load(kRelaxed) - base_count(sparse, cursor, b);
      if (n == 0) continue;
      seen += n;
      highest = b;
      while (next < 3 && seen >= ranks[next])
        *targets[next++] = value_of(b);
    }
  }
  // The maximum: the top of the highest bucket (exact below 4 us), never above the exact maximum;
  // in the open-ended last bucket, the exact maximum since start (an upper bound after a reset).
  out.max_ns =
      highest == kBuckets - 1
          ? exact_max
          : std::min(exact_max, clamp_u32(bucket_low(highest) + bucket_width(highest) - 1));
  while (next < 3)  // counts read while the loop kept recording: the tail is the maximum
    *targets[next++] = out.max_ns;
  return total;
}

std::uint32_t LoopStatisticsRecorder::jitter_p99(const Copy* base) const {
  // |period - nominal|: walk outwards from the nominal bucket, nearest first.
  const Histogram& h = (*histograms_)[kPeriod];
  const auto* sparse = base != nullptr ? &base->buckets[kPeriod] : nullptr;
  const auto count = [&](std::size_t b) -> std::uint64_t {
    std::uint32_t from_base = 0;
    if (sparse != nullptr) {
      const auto it = std::lower_bound(
          sparse->begin(), sparse->end(),
          std::pair<std::uint32_t, std::uint32_t>(static_cast<std::uint32_t>(b), 0));
      if (it != sparse->end() && it->first == b) from_base = it->second;
    }
    return h.buckets[b].load(kRelaxed) - from_base;
  };
  std::uint64_t total = 0;
  for (std::size_t g = 0; g < kGroups; ++g)
    total += h.groups[g].load(kRelaxed) - (base != nullptr ? base->groups[kPeriod][g] : 0);
  if (total == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(0.99 * static_cast<double>(total)));
  const auto distance = [&](std::size_t b) {
    const std::int64_t mid = bucket_low(b) + (bucket_width(b) - 1) / 2;
    return mid > nominal_ns_ ? mid - nominal_ns_ : nominal_ns_ - mid;
  };
  const std::size_t centre = bucket_of(nominal_ns_);
  std::int64_t below = static_cast<std::int64_t>(centre) - 1;
  std::size_t above = centre;
  std::uint64_t seen = 0;
  std::int64_t last = 0;
  while (seen < rank && (below >= 0 || above < kBuckets)) {
    const bool take_above =
        below < 0 ||
        (above < kBuckets && distance(above) <= distance(static_cast<std::size_t>(below)));
    const std::size_t b = take_above ? above++ : static_cast<std::size_t>(below--);
    if (const std::uint64_t n = count(b); n != 0) {
      seen += n;
      last = distance(b);
    }
  }
  return clamp_u32(last);
}

void LoopStatisticsRecorder::advance_window(std::int64_t now_ns) const {
  if (window_copies_.empty() || now_ns - window_copies_.back().time_ns >= kCopyIntervalNs)
    window_copies_.push_back(take_copy(now_ns));
  // Keep the newest copy that is at least kWindowNs old as the window's start; drop older ones.
  while (window_copies_.size() >= 2 && now_ns - window_copies_[1].time_ns >= kWindowNs)
    window_copies_.pop_front();
}

protocol::LoopStatistics LoopStatisticsRecorder::summary() const {
  std::lock_guard lock(reader_mutex_);
  const Copy* base = reset_base_.get();
  protocol::LoopStatistics s;
  s.rate_hz = rate_hz_;
  s.cycles = cycles() - (base != nullptr ? base->cycles : 0);
  s.overruns = overruns() - (base != nullptr ? base->overruns : 0);
  TimingQuantiles period;
  span_of(kPeriod, base, period);
  s.period_p50_ns = period.p50_ns;
  s.period_p99_ns = period.p99_ns;
  s.period_max_ns = period.max_ns;
  s.jitter_p99_ns = jitter_p99(base);
  return s;
}

TimingSummary LoopStatisticsRecorder::timing(std::int64_t now_ns) const {
  std::lock_guard lock(reader_mutex_);
  advance_window(now_ns);
  TimingSummary t;
  // The control thread keeps recording while this reads: the recent window first, then since
  // start, so that a Status never shows more recent samples than samples since start.
  const Copy& start = window_copies_.front();
  t.window_s = static_cast<float>(static_cast<double>(now_ns - start.time_ns) * 1e-9);
  t.recent.samples = span_of(kLatency, &start, t.recent.latency);
  span_of(kExecution, &start, t.recent.execution);
  span_of(kPeriod, &start, t.recent.period);
  const Copy* base = reset_base_.get();
  t.all.samples = span_of(kLatency, base, t.all.latency);
  span_of(kExecution, base, t.all.execution);
  span_of(kPeriod, base, t.all.period);
  return t;
}

void LoopStatisticsRecorder::reset(std::int64_t now_ns) {
  std::lock_guard lock(reader_mutex_);
  reset_base_ = std::make_unique<Copy>(take_copy(now_ns));
  window_copies_.clear();
  window_copies_.push_back(*reset_base_);
}

}  // namespace ajar::daemon
