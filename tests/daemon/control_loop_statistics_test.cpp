// The loop's own timing statistics: log-linear histogram (1 us resolution over the loop's range),
// latency / execution / period per cycle, since start and over a recent window, reset; and the
// seqlock that publishes the loop's snapshot.
#include <gtest/gtest.h>

#include "ajar/daemon/loop_statistics.hpp"
#include "ajar/daemon/seqlock.hpp"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <algorithm>
#include <cmath>
#include <vector>
#include <thread>

namespace ajar::daemon {
namespace {

using R = LoopStatisticsRecorder;
constexpr std::int64_t kS = 1'000'000'000;

TEST(LoopStatistics, BucketsTileTheRangeWithOneMicrosecondResolutionUpTo4ms) {
  std::size_t expected = 0;
  std::int64_t value = 0;
  while (expected < R::kBuckets) {
    ASSERT_EQ(R::bucket_low(expected), value) << expected;
    ASSERT_EQ(R::bucket_of(value), expected) << value;
    ASSERT_EQ(R::bucket_of(value + R::bucket_width(expected) - 1), expected) << value;
    if (value < 4'194'304) {
      ASSERT_LE(R::bucket_width(expected), 1024) << value;
    }
    if (value < 4096) {
      ASSERT_EQ(R::bucket_width(expected), 1) << value;
    }
    // relative width at most 1/2048 above the exact range
    if (value >= 4096) {
      ASSERT_LE(R::bucket_width(expected) * 2048, value) << value;
    }
    value += R::bucket_width(expected);
    ++expected;
  }
  EXPECT_EQ(value, std::int64_t{1} << R::kMaxValueBits);
  EXPECT_EQ(R::bucket_of(-5), 0U);
  EXPECT_EQ(R::bucket_of(std::int64_t{1} << 40), R::kBuckets - 1);
}

TEST(LoopStatistics, LatencyExecutionAndPeriodPercentiles) {
  R r(500);  // 2 ms nominal
  EXPECT_EQ(r.nominal_period_ns(), 2'000'000);
  std::int64_t deadline = kS;
  // 1000 cycles: latency 10 us except 20 at 300 us and one at 5 ms; execution 50 us.
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t latency = i == 500 ? 5'000'000 : (i % 50 == 7 ? 300'000 : 10'000);
    r.record_cycle(deadline, deadline + latency, deadline + latency + 50'000);
    deadline += 2'000'000;
  }
  const auto t = r.timing(deadline);
  EXPECT_EQ(t.all.samples, 1000U);
  EXPECT_NEAR(t.all.latency.p50_ns, 10'000,
              2);  // a 4 ns bucket's midpoint, not a 7.8 us bin's edge
  EXPECT_NEAR(t.all.latency.p99_ns, 300'000, 64);
  EXPECT_NEAR(t.all.latency.p999_ns, 300'000, 64);
  EXPECT_EQ(t.all.latency.max_ns, 5'000'000U);
  EXPECT_NEAR(t.all.execution.p50_ns, 50'000, 8);
  EXPECT_EQ(t.all.execution.max_ns, 50'000U);
  // Periods: mostly 2 ms; 2 ms + 290 us into a late wake-up, 2 ms - 290 us after it.
  EXPECT_NEAR(t.all.period.p50_ns, 2'000'000, 512);
  EXPECT_NEAR(t.all.period.p99_ns, 2'290'000, 1024);
  EXPECT_NEAR(t.all.period.max_ns, 6'990'000, 2048);
  const auto s = r.summary();
  EXPECT_EQ(s.rate_hz, 500.0F);
  EXPECT_EQ(s.cycles, 1000U);
  EXPECT_NEAR(s.period_p50_ns, 2'000'000, 512);
  EXPECT_NEAR(s.jitter_p99_ns, 290'000, 1024);
  EXPECT_EQ(s.period_max_ns, t.all.period.max_ns);
}

TEST(LoopStatistics, RecentWindowForgetsOldCyclesAndResetRestartsEverything) {
  R r(1000);
  std::int64_t now = kS;
  const auto run = [&](std::int64_t seconds, std::int64_t latency_ns) {
    for (std::int64_t i = 0; i < seconds * 1000; ++i) {
      r.record_cycle(now, now + latency_ns, now + latency_ns + 1000);
      now += 1'000'000;
      if (i % 500 == 0) (void)r.timing(now);  // a client reads twice a second
    }
  };
  run(12, 900'000);  // a bad start: 900 us latency
  run(15, 20'000);   // then 20 us for 15 s
  const auto t = r.timing(now);
  EXPECT_EQ(t.all.samples, 27'000U);
  EXPECT_NEAR(t.all.latency.max_ns, 900'000, 512);
  EXPECT_GE(t.window_s, 10.0F);
  EXPECT_LE(t.window_s, 12.5F);
  EXPECT_NEAR(static_cast<double>(t.recent.samples), static_cast<double>(t.window_s) * 1000.0, 2.0);
  EXPECT_NEAR(t.recent.latency.max_ns, 20'000, 8);  // the bad start is out of the window
  EXPECT_NEAR(t.recent.latency.p999_ns, 20'000, 8);

  r.record_overrun();
  EXPECT_EQ(r.summary().overruns, 1U);
  r.reset(now);
  const auto fresh = r.timing(now);
  EXPECT_EQ(fresh.all.samples, 0U);
  EXPECT_EQ(fresh.all.latency.max_ns, 0U);
  EXPECT_EQ(fresh.recent.samples, 0U);
  EXPECT_EQ(r.summary().overruns, 0U);
  // Every counter of the summary restarts (issue 24: cycles kept counting since start while
  // overruns restarted, so overruns / cycles meant nothing after a reset).
  EXPECT_EQ(r.summary().cycles, 0U);
  EXPECT_EQ(r.cycles(), 27'000U);  // the recorder's own counter still counts since start
  run(1, 30'000);
  const auto after = r.timing(now);
  EXPECT_EQ(after.all.samples, 1000U);
  EXPECT_NEAR(after.all.latency.p50_ns, 30'000, 8);
  EXPECT_NEAR(after.all.latency.max_ns, 30'000, 8);
  EXPECT_EQ(after.recent.samples, 1000U);
  EXPECT_EQ(r.summary().cycles, after.all.samples);  // the same span as timing.all
}

TEST(LoopStatistics, PercentilesMatchASortedReferenceWithinOneBucket) {
  const char* env = std::getenv("AJAR_SEED");
  const std::uint64_t seed =
      env != nullptr ? std::strtoull(env, nullptr, 10) : std::random_device{}();
  std::printf("AJAR_SEED=%llu\n", static_cast<unsigned long long>(seed));
  std::mt19937_64 rng(seed);
  std::lognormal_distribution<double> dist(std::log(20'000.0), 1.0);
  R r(500);
  std::vector<std::int64_t> latencies;
  std::int64_t deadline = kS;
  for (int i = 0; i < 20'000; ++i) {
    const auto l = static_cast<std::int64_t>(dist(rng));
    latencies.push_back(l);
    r.record_cycle(deadline, deadline + l, deadline + l + 1);
    deadline += 2'000'000;
  }
  std::sort(latencies.begin(), latencies.end());
  const auto t = r.timing(deadline);
  const auto at = [&](double f) {
    return latencies[static_cast<std::size_t>(
                         std::ceil(f * static_cast<double>(latencies.size()))) -
                     1];
  };
  for (const auto& [f, got] :
       {std::pair{0.5, t.all.latency.p50_ns}, std::pair{0.99, t.all.latency.p99_ns},
        std::pair{0.999, t.all.latency.p999_ns}}) {
    const std::int64_t want = at(f);
    EXPECT_LE(std::llabs(static_cast<std::int64_t>(got) - want),
              R::bucket_width(R::bucket_of(want)))
        << "p" << f * 100 << " seed " << seed;
  }
  EXPECT_EQ(t.all.latency.max_ns, static_cast<std::uint32_t>(latencies.back()));
}

TEST(LoopStatistics, AStallBeyondTheHistogramIsReportedExactly) {
  R r(500);
  std::int64_t d = kS;
  for (int i = 0; i < 10; ++i, d += 2'000'000)
    r.record_cycle(d, d + 10'000, d + 20'000);
  r.record_cycle(d, d + 400'000'000, d + 400'010'000);  // a 400 ms stall: beyond 2^28 ns
  const auto t = r.timing(d + kS);
  EXPECT_EQ(t.all.latency.max_ns, 400'000'000U);
  EXPECT_EQ(t.all.period.max_ns, 401'990'000U);  // from the previous wake-up, 10 us late
  EXPECT_EQ(r.summary().period_max_ns, 401'990'000U);
}

TEST(LoopStatistics, EmptyIsZero) {
  R r(1000);
  const auto s = r.summary();
  EXPECT_EQ(s.cycles, 0U);
  EXPECT_EQ(s.period_p50_ns, 0U);
  EXPECT_EQ(s.period_max_ns, 0U);
  const auto t = r.timing(kS);
  EXPECT_EQ(t.all.samples, 0U);
  EXPECT_EQ(t.recent.latency.max_ns, 0U);
}

TEST(LoopStatistics, ReadersRunConcurrentlyWithTheRecordingThread) {
  R r(1000);
  std::atomic<bool> done{false};
  std::thread loop([&] {
    std::int64_t d = kS;
    for (int i = 0; i < 200'000; ++i, d += 1'000'000)
      r.record_cycle(d, d + 5'000 + (i % 7) * 1000, d + 30'000);
    done = true;
  });
  std::uint64_t last = 0;
  std::int64_t now = kS;
  while (!done) {
    const auto t = r.timing(now += 1'000'000);
    ASSERT_GE(t.all.samples, last);
    last = t.all.samples;
    if (t.all.samples > 0) {
      ASSERT_GE(t.all.latency.p50_ns, 5'000U);
      ASSERT_LE(t.all.latency.max_ns, 11'000U);
    }
  }
  loop.join();
  EXPECT_EQ(r.timing(now).all.samples, 200'000U);
}

struct Wide {
  std::uint64_t a = 0, b = 0, c = 0;
  double d = 0;
};

// Publishes Wide{i, i, i, i} for i = 1..20000, then sets `done`.
std::thread publish_counting(SeqLock<Wide>& lock, std::atomic<bool>& done) {
  return std::thread([&lock, &done] {
    for (std::uint64_t i = 1; i <= 20000; ++i) {
      lock.store(Wide{i, i, i, static_cast<double>(i)});
    }
    done = true;
  });
}
// One value publish_counting() published, not parts of two.
bool is_whole(const Wide& w) {
  return w.a == w.b && w.b == w.c && static_cast<double>(w.a) == w.d;
}

TEST(SeqLock, ReaderNeverSeesATornValue) {
  SeqLock<Wide> lock;
  std::atomic<bool> done{false};
  std::thread writer = publish_counting(lock, done);
  std::uint64_t last = 0;
  while (!done) {
    const Wide w = lock.load();
    ASSERT_TRUE(is_whole(w)) << w.a << " " << w.b << " " << w.c << " " << w.d;
    ASSERT_GE(w.a, last);  // published values only move forward
    last = w.a;
  }
  writer.join();
  EXPECT_EQ(lock.load().a, 20000U);
}

TEST(SeqLock, TryLoadNeverWaitsAndNeverSeesATornValue) {
  // One attempt: a read that overlaps a store fails (value untouched) rather than spinning, and
  // a read that succeeds is a whole published value.
  SeqLock<Wide> lock;
  std::atomic<bool> done{false};
  std::thread writer = publish_counting(lock, done);
  std::uint64_t last = 0;
  while (!done) {
    Wide w{7, 0, 0, 0.0};
    if (!lock.try_load(w)) {
      ASSERT_EQ(w.a, 7U);  // untouched
      continue;
    }
    ASSERT_TRUE(is_whole(w)) << w.a << " " << w.b << " " << w.c << " " << w.d;
    ASSERT_GE(w.a, last);
    last = w.a;
  }
  writer.join();
  Wide w{};
  ASSERT_TRUE(lock.try_load(w)) << "no writer: the first attempt succeeds";
  EXPECT_EQ(w.a, 20000U);
}

}  // namespace
}  // namespace ajar::daemon
