// The loop's ring (spsc_ring.hpp): nothing dropped under capacity, drops counted above it, and a
// randomized producer/consumer (seed printed; AJAR_SEED=... replays one) that never sees a torn,
// reordered or duplicated record.
#include "ajar/recorder/spsc_ring.hpp"

#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>

namespace ajar::recorder {
namespace {

struct Item {
  std::uint64_t sequence = 0;
  std::uint64_t payload[6] = {};  // each = sequence * (i + 1): a torn copy shows
};
Item make(std::uint64_t s) {
  Item it;
  it.sequence = s;
  for (std::uint64_t i = 0; i < 6; ++i)
    it.payload[i] = s * (i + 1);
  return it;
}
bool intact(const Item& it) {
  for (std::uint64_t i = 0; i < 6; ++i) {
    if (it.payload[i] != it.sequence * (i + 1)) return false;
  }
  return true;
}

TEST(SpscRing, NothingIsDroppedUnderCapacityAndOrderIsKept) {
  SpscRing<Item, 64> ring;
  for (std::uint64_t round = 0; round < 3; ++round) {
    for (std::uint64_t i = 0; i < 64; ++i)
      ASSERT_TRUE(ring.push(make(round * 64 + i)));
    Item it;
    for (std::uint64_t i = 0; i < 64; ++i) {
      ASSERT_TRUE(ring.pop(it));
      EXPECT_EQ(it.sequence, round * 64 + i);
      EXPECT_TRUE(intact(it));
    }
    EXPECT_FALSE(ring.pop(it));
  }
  EXPECT_EQ(ring.dropped(), 0U);
  EXPECT_EQ(ring.pushed(), 192U);
}

TEST(SpscRing, AFullRingDropsTheNewRecordAndCountsIt) {
  SpscRing<Item, 8> ring;
  for (std::uint64_t i = 0; i < 8; ++i)
    ASSERT_TRUE(ring.push(make(i)));
  for (std::uint64_t i = 8; i < 13; ++i)
    EXPECT_FALSE(ring.push(make(i)));
  EXPECT_EQ(ring.dropped(), 5U);
  Item it;
  ASSERT_TRUE(ring.pop(it));
  EXPECT_EQ(it.sequence, 0U) << "the oldest stays: drops are of the new records";
  EXPECT_TRUE(ring.push(make(100)));  // room again
  for (std::uint64_t i = 1; i < 8; ++i) {
    ASSERT_TRUE(ring.pop(it));
    EXPECT_EQ(it.sequence, i);
  }
  ASSERT_TRUE(ring.pop(it));
  EXPECT_EQ(it.sequence, 100U);
}

TEST(SpscRing, RandomizedProducerAndConsumerLoseNothingButWhatTheyCount) {
  std::uint64_t seed = std::random_device{}();
  if (const char* s = std::getenv("AJAR_SEED")) seed = std::stoull(s);
  std::cout << "SpscRing campaign seed " << seed << " (AJAR_SEED=" << seed << " replays it)\n";
  RecordProperty("seed", std::to_string(seed));
  constexpr std::uint64_t kItems = 200000;
  SpscRing<Item, 256> ring;
  std::uint64_t accepted = 0;
  std::thread producer([&] {
    std::mt19937_64 rng(seed);
    for (std::uint64_t s = 0; s < kItems; ++s) {
      if (ring.push(make(s))) ++accepted;
      if (rng() % 64 == 0) std::this_thread::yield();  // bursts and pauses
    }
  });
  std::mt19937_64 rng(seed ^ 0x9E3779B97F4A7C15ULL);
  std::uint64_t popped = 0, last = 0;
  bool first = true;
  Item it;
  for (;;) {
    const bool done = ring.pushed() + ring.dropped() == kItems;  // producer finished offering
    while (ring.pop(it)) {
      ASSERT_TRUE(intact(it)) << "torn record " << it.sequence << " seed " << seed;
      ASSERT_TRUE(first || it.sequence > last) << "reordered/duplicated, seed " << seed;
      first = false;
      last = it.sequence;
      ++popped;
      if (rng() % 128 == 0) std::this_thread::yield();
    }
    if (done) break;  // everything offered was pushed before `done`, and popped above
    if (rng() % 4 == 0) std::this_thread::yield();
  }
  producer.join();
  EXPECT_EQ(popped, accepted) << "seed " << seed;
  EXPECT_EQ(popped + ring.dropped(), kItems) << "seed " << seed;
}

}  // namespace
}  // namespace ajar::recorder
