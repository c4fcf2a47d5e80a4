// The tests' own reading of MCAP bytes (the specification's record framing), independent of the
// writer: whole records from the start, stopping at a cut.
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "ajar/recorder/mcap_writer.hpp"

namespace ajar::recorder::test {

struct ReadMessage {
  std::uint16_t channel = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;
  std::vector<std::uint8_t> data;
};

struct ReadFile {
  bool magic = false;     // leading magic
  bool complete = false;  // Footer and trailing magic
  std::vector<std::uint8_t> ops;
  std::vector<ReadMessage> messages;
  std::map<std::uint16_t, std::uint64_t> counts;  // per channel
};

inline std::uint64_t le(const std::vector<std::uint8_t>& b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i)
    v |= std::uint64_t{b[at + static_cast<std::size_t>(i)]} << (8 * i);
  return v;
}

inline ReadFile read_mcap(const std::vector<std::uint8_t>& b) {
  ReadFile f;
  f.magic = b.size() >= 8 && std::memcmp(b.data(), kMcapMagic, 8) == 0;
  if (!f.magic) return f;
  std::size_t at = 8;
  bool in_summary = false;
  while (at + 9 <= b.size()) {
    const std::uint8_t op = b[at];
    const std::uint64_t len = le(b, at + 1, 8);
    if (at + 9 + len > b.size()) break;  // cut inside this record
    const std::size_t c = at + 9;
    f.ops.push_back(op);
    if (op == 0x0F) in_summary = true;
    if (op == 0x05 && !in_summary) {
      ReadMessage m;
      m.channel = static_cast<std::uint16_t>(le(b, c, 2));
      m.sequence = static_cast<std::uint32_t>(le(b, c + 2, 4));
      m.log_time = le(b, c + 6, 8);
      m.data.assign(b.begin() + static_cast<std::ptrdiff_t>(c + 22),
                    b.begin() + static_cast<std::ptrdiff_t>(c + len));
      ++f.counts[m.channel];
      f.messages.push_back(std::move(m));
    }
    at = c + static_cast<std::size_t>(len);
    if (op == 0x02) {
      f.complete = at + 8 == b.size() && std::memcmp(b.data() + at, kMcapMagic, 8) == 0;
      break;
    }
  }
  return f;
}

inline std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace ajar::recorder::test
