// The randomized campaigns' sizes and seeds (interleaving, crash, certificate): one reading of the
// environment for all of them, so `AJAR_SEED=<n>` replays one trial and `AJAR_SEEDS=<n>` sets how
// many, the same way in every campaign.
#pragma once

#include <cstdint>
#include <cstdlib>

namespace ajar::test {

// ASan/TSan cost 10-20x the CPU: CI runs a shorter campaign there (the Release run asserts
// coverage).
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

// CI's size: `release` in Release, `sanitized` under a sanitizer.
constexpr std::uint64_t ci_size(std::uint64_t release, std::uint64_t sanitized) {
  return kSanitized ? sanitized : release;
}

// The environment variable `name` as a whole number; `fallback` when it is unset or empty.
inline std::uint64_t env_u64(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::strtoull(v, nullptr, 10) : fallback;
}

// The seeds a campaign runs: AJAR_SEED=<n> replays seed n alone (`replay`), else AJAR_SEEDS seeds
// from 1 (`ci_seeds` when unset).
struct SeedRange {
  std::uint64_t first = 1;
  std::uint64_t count = 0;
  bool replay = false;
};
inline SeedRange seed_range(std::uint64_t ci_seeds) {
  if (const char* one = std::getenv("AJAR_SEED"); one != nullptr && *one != '\0') {
    return {env_u64("AJAR_SEED", 0), 1, true};
  }
  return {1, env_u64("AJAR_SEEDS", ci_seeds), false};
}

}  // namespace ajar::test
