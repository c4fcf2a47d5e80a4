// The loop's own timing statistics: fixed histogram, no allocation, percentiles from bins.
#include <gtest/gtest.h>

#include "ajar/daemon/loop_statistics.hpp"
#include "ajar/daemon/seqlock.hpp"

#include <atomic>
#include <thread>

namespace ajar::daemon {
namespace {

TEST(LoopStatistics, PercentilesMaximumAndOverruns) {
  LoopStatisticsRecorder r(500);  // 2 ms nominal
  EXPECT_EQ(r.nominal_period_ns(), 2'000'000);
  for (int i = 0; i < 980; ++i)
    r.record_period(2'000'000);
  for (int i = 0; i < 20; ++i)
    r.record_period(3'000'000);
  r.record_period(50'000'000);  // a 50 ms stall: beyond the histogram, kept as the maximum
  r.record_overrun();
  const auto s = r.summary();
  const std::uint32_t bin = 2'000'000 / LoopStatisticsRecorder::kBinsPerPeriod;
  EXPECT_EQ(s.rate_hz, 500.0F);
  EXPECT_EQ(s.cycles, 1001U);
  EXPECT_EQ(s.overruns, 1U);
  EXPECT_GE(s.period_p50_ns, 2'000'000U);
  EXPECT_LE(s.period_p50_ns, 2'000'000U + bin);
  EXPECT_GE(s.period_p99_ns, 3'000'000U);
  EXPECT_LE(s.period_p99_ns, 3'000'000U + bin);
  EXPECT_EQ(s.period_max_ns, 50'000'000U);
  EXPECT_GE(s.jitter_p99_ns, 1'000'000U);
  EXPECT_LE(s.jitter_p99_ns, 1'000'000U + bin);
}

TEST(LoopStatistics, EmptyIsZero) {
  const auto s = LoopStatisticsRecorder(1000).summary();
  EXPECT_EQ(s.cycles, 0U);
  EXPECT_EQ(s.period_p50_ns, 0U);
  EXPECT_EQ(s.period_max_ns, 0U);
}

struct Wide {
  std::uint64_t a = 0, b = 0, c = 0;
  double d = 0;
};

TEST(SeqLock, ReaderNeverSeesATornValue) {
  SeqLock<Wide> lock;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= 20000; ++i) {
      lock.store(Wide{i, i, i, static_cast<double>(i)});
    }
    done = true;
  });
  std::uint64_t last = 0;
  while (!done) {
    const Wide w = lock.load();
    ASSERT_EQ(w.a, w.b);
    ASSERT_EQ(w.b, w.c);
    ASSERT_EQ(static_cast<double>(w.a), w.d);
    ASSERT_GE(w.a, last);  // published values only move forward
    last = w.a;
  }
  writer.join();
  EXPECT_EQ(lock.load().a, 20000U);
}

}  // namespace
}  // namespace ajar::daemon
