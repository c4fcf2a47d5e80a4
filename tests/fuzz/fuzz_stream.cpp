// Fuzzes the StreamDecoder. Byte 0 of the input seeds the chunking; the rest is the byte stream.
// Property: feeding the stream in random chunks (1 byte .. whole) gives exactly the same sequence
// of outcomes as feeding it all at once, and every decoded message survives a re-encode.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "ajar/protocol/codec.hpp"

using namespace ajar::protocol;

namespace {

struct Seen {
  StreamDecoder::Kind kind;
  ajar::ErrorCode code;
  bool framing_lost;
  const char* field;
  std::uint32_t request_id;
  std::uint16_t type_or_flags;
  Message message;
};

template <typename NextChunk>
std::vector<Seen> run(std::span<const std::uint8_t> stream, NextChunk next_chunk) {
  std::vector<Seen> seen;
  StreamDecoder decoder;
  StreamDecoder::Outcome o;
  while (!stream.empty()) {
    auto chunk = stream.first(std::min(next_chunk(), stream.size()));
    stream = stream.subspan(chunk.size());
    while (!chunk.empty()) {
      const std::size_t used = decoder.feed(chunk, o);
      if (used == 0 || used > chunk.size()) std::abort();
      chunk = chunk.subspan(used);
      if (o.kind == StreamDecoder::Kind::kMessage) {
        seen.push_back({o.kind, ajar::ErrorCode::kOk, false, "", o.envelope.request_id,
                        o.envelope.flags, o.envelope.message});
      } else if (o.kind == StreamDecoder::Kind::kError) {
        seen.push_back({o.kind, o.error.code, o.error.framing_lost, o.error.field,
                        o.error.request_id, o.error.type, Ping{}});
        if (o.error.framing_lost) return seen;  // stays failed: nothing more to learn
      }
    }
  }
  return seen;
}

void check_roundtrip(const Seen& s) {
  std::array<std::uint8_t, kMaxFrameSize> out{};
  const std::size_t n = encode(Envelope{s.request_id, s.type_or_flags, s.message}, out);
  if (n == 0) std::abort();
  const auto again = decode_frame(std::span(out.data(), n));
  if (again.kind != StreamDecoder::Kind::kMessage ||
      !wire_equal(again.envelope.message, s.message)) {
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  std::uint32_t state = data[0] * 2654435761u + 1;
  const std::span<const std::uint8_t> stream(data + 1, size - 1);
  const auto whole = run(stream, [&] { return stream.size(); });
  const auto chunked = run(stream, [&] {
    state = state * 1664525u + 1013904223u;
    const std::uint32_t r = state >> 24;
    return static_cast<std::size_t>(r < 64 ? 1 : r < 192 ? (r % 23) + 1 : r * 4);
  });
  if (whole.size() != chunked.size()) std::abort();
  for (std::size_t i = 0; i < whole.size(); ++i) {
    const Seen& a = whole[i];
    const Seen& b = chunked[i];
    if (a.kind != b.kind || a.code != b.code || a.framing_lost != b.framing_lost ||
        std::strcmp(a.field, b.field) != 0 || a.request_id != b.request_id ||
        a.type_or_flags != b.type_or_flags || !wire_equal(a.message, b.message)) {
      std::abort();
    }
    if (a.kind == StreamDecoder::Kind::kMessage) check_roundtrip(a);
  }
  return 0;
}
