// CRC-32C: every implementation (table; SSE4.2 or ARMv8 when this CPU has it) gives the same
// results, and the golden vectors pass with each one forced in turn. Random inputs print their seed
// (replay with AJAR_SEED=<seed>).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/crc32c.hpp"
#include "ajar/protocol/vectors.hpp"

namespace ajar::protocol {
namespace {

constexpr Crc32cPath kAllPaths[] = {Crc32cPath::kTable, Crc32cPath::kSse42, Crc32cPath::kArmv8};

std::uint32_t crc_with(Crc32cPath path, std::string_view text) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(text.data());
  return crc32c_finish(crc32c_update_with(path, kCrc32cInit, p, text.size()));
}

// Restores the automatically selected path when a test ends.
struct PathGuard {
  Crc32cPath saved = crc32c_path();
  ~PathGuard() { force_crc32c_path(saved); }
};

TEST(Crc32c, TableIsAlwaysAvailableAndTheHardwarePathIsPickedWhenPresent) {
  EXPECT_TRUE(crc32c_available(Crc32cPath::kTable));
  const bool hw = crc32c_available(Crc32cPath::kSse42) || crc32c_available(Crc32cPath::kArmv8);
  EXPECT_EQ(crc32c_path() != Crc32cPath::kTable, hw) << to_string(crc32c_path());
  EXPECT_FALSE(crc32c_available(Crc32cPath::kSse42) && crc32c_available(Crc32cPath::kArmv8));
  std::printf("CRC-32C path in use: %s\n", std::string(to_string(crc32c_path())).c_str());
}

// A run that must prove which implementation it exercised names it: AJAR_EXPECT_CRC32C_PATH=armv8
// (scripts/test-arm64, under qemu-aarch64) fails unless the ARMv8 instruction is available and is
// the one in use, so the golden vectors and the frames of every other test went through it.
TEST(Crc32c, ThePathNamedByTheRunIsTheOneInUse) {
  const char* expected = std::getenv("AJAR_EXPECT_CRC32C_PATH");
  if (expected == nullptr) GTEST_SKIP() << "AJAR_EXPECT_CRC32C_PATH is not set";
  bool known = false;
  for (const auto path : kAllPaths) {
    if (to_string(path) != expected) continue;
    known = true;
    EXPECT_TRUE(crc32c_available(path)) << expected << " is not available on this CPU";
  }
  EXPECT_TRUE(known) << "AJAR_EXPECT_CRC32C_PATH=" << expected
                     << " names no path (table, sse4.2, armv8)";
  EXPECT_EQ(std::string(to_string(crc32c_path())), std::string(expected));
  std::printf("CRC-32C path in use: %s (expected %s)\n",
              std::string(to_string(crc32c_path())).c_str(), expected);
}

TEST(Crc32c, KnownValuesOnEveryPath) {
  // RFC 3720 (iSCSI) B.4 and the usual check value.
  const std::vector<std::uint8_t> zeros(32, 0x00), ones(32, 0xFF);
  std::vector<std::uint8_t> inc(32), dec(32);
  for (std::size_t i = 0; i < 32; ++i) {
    inc[i] = static_cast<std::uint8_t>(i);
    dec[i] = static_cast<std::uint8_t>(31 - i);
  }
  int tested = 0;
  for (const auto path : kAllPaths) {
    if (!crc32c_available(path)) continue;
    ++tested;
    SCOPED_TRACE(std::string(to_string(path)));
    const auto raw = [&](const std::vector<std::uint8_t>& b) {
      return crc32c_finish(crc32c_update_with(path, kCrc32cInit, b.data(), b.size()));
    };
    EXPECT_EQ(crc_with(path, "123456789"), 0xE3069283u);
    EXPECT_EQ(crc_with(path, ""), 0x00000000u);
    EXPECT_EQ(crc_with(path, "a"), 0xC1D04330u);
    EXPECT_EQ(raw(zeros), 0x8A9136AAu);
    EXPECT_EQ(raw(ones), 0x62A8AB43u);
    EXPECT_EQ(raw(inc), 0x46DD794Eu);
    EXPECT_EQ(raw(dec), 0x113FDB5Cu);
  }
  EXPECT_GE(tested, 1);
}

TEST(Crc32c, PathsAgreeOnRandomLengthsAlignmentsAndSplits) {
  const char* env = std::getenv("AJAR_SEED");
  const std::uint64_t seed =
      env != nullptr ? std::strtoull(env, nullptr, 10) : std::random_device{}();
  std::printf("AJAR_SEED=%llu\n", static_cast<unsigned long long>(seed));
  std::mt19937_64 rng(seed);
  std::vector<std::uint8_t> buffer(2048 + 16);
  for (auto& b : buffer)
    b = static_cast<std::uint8_t>(rng());
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t offset = rng() % 16;  // every alignment
    const std::size_t size = rng() % 2049;
    const std::size_t split = size == 0 ? 0 : rng() % (size + 1);
    const std::uint8_t* p = buffer.data() + offset;
    const std::uint32_t whole =
        crc32c_finish(crc32c_update_with(Crc32cPath::kTable, kCrc32cInit, p, size));
    for (const auto path : kAllPaths) {
      if (!crc32c_available(path)) continue;
      const std::uint32_t first = crc32c_update_with(path, kCrc32cInit, p, split);
      const std::uint32_t both =
          crc32c_finish(crc32c_update_with(path, first, p + split, size - split));
      ASSERT_EQ(both, whole) << to_string(path) << " offset " << offset << " size " << size
                             << " split " << split << " seed " << seed;
    }
  }
}

TEST(Crc32c, ForcingAnUnavailablePathChangesNothing) {
  PathGuard guard;
  const Crc32cPath before = crc32c_path();
  for (const auto path : kAllPaths) {
    if (crc32c_available(path)) continue;
    EXPECT_FALSE(force_crc32c_path(path));
    EXPECT_EQ(crc32c_path(), before);
  }
}

std::vector<GoldenVector> load_vectors() {
  std::vector<GoldenVector> out;
  for (const auto& entry : std::filesystem::directory_iterator(AJAR_VECTOR_DIR)) {
    if (entry.path().extension() != ".vec") continue;
    std::ifstream f(entry.path(), std::ios::binary);
    std::stringstream text;
    text << f.rdbuf();
    auto v = parse_vector(text.str());
    if (v.ok()) out.push_back(std::move(v).value());
  }
  return out;
}

TEST(Crc32c, GoldenVectorsPassThroughEveryPath) {
  PathGuard guard;
  const auto vectors = load_vectors();
  ASSERT_GE(vectors.size(), 40u);
  bool saw_crc_error = false;
  for (const auto path : kAllPaths) {
    if (!crc32c_available(path)) continue;
    ASSERT_TRUE(force_crc32c_path(path));
    ASSERT_EQ(crc32c_path(), path);
    for (const auto& v : vectors) {
      const auto result = check_vector(v);
      EXPECT_TRUE(result.ok()) << to_string(path) << " " << v.name << ": "
                               << (result.ok() ? "" : result.error().message);
      saw_crc_error =
          saw_crc_error || (!v.expect_ok && v.expected_error == ErrorCode::kCrcMismatch);
    }
  }
  EXPECT_TRUE(saw_crc_error);  // the set includes a frame whose CRC is wrong
}

}  // namespace
}  // namespace ajar::protocol
