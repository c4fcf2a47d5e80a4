// StreamDecoder: any chunking gives the same messages; errors skip one frame or stop the stream.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "samples.hpp"

namespace ajar::protocol {
namespace {

using Bytes = std::vector<std::uint8_t>;

struct Collected {
  std::vector<Envelope> messages;
  std::vector<DecodeError> errors;
};

// Feeds `stream` in chunks whose sizes come from `next_chunk`; collects every outcome.
template <typename NextChunk>
Collected feed_all(const Bytes& stream, NextChunk next_chunk, StreamDecoder& decoder) {
  Collected c;
  std::size_t pos = 0;
  StreamDecoder::Outcome o;
  while (pos < stream.size()) {
    std::span<const std::uint8_t> chunk(stream.data() + pos,
                                        std::min(next_chunk(), stream.size() - pos));
    pos += chunk.size();
    while (!chunk.empty()) {
      const std::size_t used = decoder.feed(chunk, o);
      EXPECT_LE(used, chunk.size());
      chunk = chunk.subspan(used);
      if (o.kind == StreamDecoder::Kind::kMessage) c.messages.push_back(o.envelope);
      if (o.kind == StreamDecoder::Kind::kError) {
        c.errors.push_back(o.error);
        if (o.error.framing_lost) return c;
      }
      if (used == 0) {
        ADD_FAILURE() << "feed consumed nothing from a non-empty chunk";
        return c;
      }
    }
  }
  return c;
}

Bytes all_samples_stream(int repeats) {
  Bytes b;
  for (int r = 0; r < repeats; ++r) {
    for (const auto& s : samples::all())
      EXPECT_TRUE(encode_append(s.envelope, b));
  }
  return b;
}

void expect_all_samples(const Collected& c, int repeats) {
  const auto expected = samples::all();
  ASSERT_TRUE(c.errors.empty()) << to_string(c.errors.front().code);
  ASSERT_EQ(c.messages.size(), expected.size() * static_cast<std::size_t>(repeats));
  for (std::size_t i = 0; i < c.messages.size(); ++i) {
    const auto& want = expected[i % expected.size()].envelope;
    EXPECT_EQ(c.messages[i].request_id, want.request_id);
    EXPECT_EQ(c.messages[i].flags, want.flags);
    EXPECT_TRUE(wire_equal(c.messages[i].message, want.message)) << i;
  }
}

TEST(Stream, OneByteAtATime) {
  StreamDecoder d;
  expect_all_samples(feed_all(
                         all_samples_stream(2), [] { return std::size_t{1}; }, d),
                     2);
}

TEST(Stream, AllInOneBuffer) {
  StreamDecoder d;
  const Bytes b = all_samples_stream(3);
  expect_all_samples(feed_all(
                         b, [&] { return b.size(); }, d),
                     3);
}

TEST(Stream, RandomChunks) {
  const Bytes b = all_samples_stream(4);
  for (unsigned seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE(seed);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> size(1, seed % 2 ? 40 : 700);
    StreamDecoder d;
    expect_all_samples(feed_all(
                           b, [&] { return size(rng); }, d),
                       4);
  }
}

TEST(Stream, ChunkBoundaryInsideEveryHeaderPosition) {
  const Bytes b = all_samples_stream(1);
  for (std::size_t first = 1; first < 60; ++first) {
    bool used_first = false;
    StreamDecoder d;
    expect_all_samples(feed_all(
                           b,
                           [&] {
                             if (used_first) return std::size_t{97};
                             used_first = true;
                             return first;
                           },
                           d),
                       1);
  }
}

TEST(Stream, NonFatalErrorSkipsExactlyOneFrame) {
  Bytes b;
  ASSERT_TRUE(encode_append(Envelope{1, 0, Ping{1}}, b));
  const std::size_t bad_at = b.size();
  ASSERT_TRUE(encode_append(Envelope{2, 0, Ping{2}}, b));
  b[bad_at + 25] ^= 0x10;  // corrupt the second frame's payload: CRC mismatch
  ASSERT_TRUE(encode_append(Envelope{3, 0, Ping{3}}, b));
  for (std::size_t chunk : {std::size_t{1}, std::size_t{7}, b.size()}) {
    StreamDecoder d;
    const auto c = feed_all(
        b, [&] { return chunk; }, d);
    ASSERT_EQ(c.errors.size(), 1u);
    EXPECT_EQ(c.errors[0].code, ErrorCode::kCrcMismatch);
    EXPECT_EQ(c.errors[0].request_id, 2u);
    ASSERT_EQ(c.messages.size(), 2u);
    EXPECT_EQ(c.messages[0].request_id, 1u);
    EXPECT_EQ(c.messages[1].request_id, 3u);
  }
}

TEST(Stream, BadMagicIsDetectedAtTheFirstWrongByteAndSticks) {
  StreamDecoder d;
  StreamDecoder::Outcome o;
  const Bytes junk = {'A', 'J', 'X'};
  EXPECT_EQ(d.feed(std::span(junk).first(1), o), 1u);
  EXPECT_EQ(o.kind, StreamDecoder::Kind::kNeedMore);
  EXPECT_EQ(d.feed(std::span(junk).subspan(1), o), 2u);
  ASSERT_EQ(o.kind, StreamDecoder::Kind::kError);
  EXPECT_EQ(o.error.code, ErrorCode::kBadMagic);
  EXPECT_TRUE(o.error.framing_lost);
  // Stays failed, even for a valid frame, and consumes what it is given.
  Bytes ping;
  ASSERT_TRUE(encode_append(Envelope{1, 0, Ping{}}, ping));
  EXPECT_EQ(d.feed(ping, o), ping.size());
  ASSERT_EQ(o.kind, StreamDecoder::Kind::kError);
  EXPECT_EQ(o.error.code, ErrorCode::kBadMagic);
  d.reset();
  EXPECT_EQ(d.feed(ping, o), ping.size());
  EXPECT_EQ(o.kind, StreamDecoder::Kind::kMessage);
}

TEST(Stream, OversizeIsRefusedFromTheHeaderAlone) {
  Bytes b;
  ASSERT_TRUE(encode_append(Envelope{9, 0, Ping{}}, b));
  b.resize(kHeaderSize);
  b[kOffsetPayloadLength] = 0xFF;
  b[kOffsetPayloadLength + 1] = 0xFF;
  b[kOffsetPayloadLength + 2] = 0xFF;
  b[kOffsetPayloadLength + 3] = 0x7F;  // 2 GiB
  StreamDecoder d;
  StreamDecoder::Outcome o;
  EXPECT_EQ(d.feed(b, o), kHeaderSize);
  ASSERT_EQ(o.kind, StreamDecoder::Kind::kError);
  EXPECT_EQ(o.error.code, ErrorCode::kPayloadTooLarge);
  EXPECT_TRUE(o.error.framing_lost);
  EXPECT_EQ(o.error.request_id, 9u);
}

TEST(Stream, PartialFrameNeedsMore) {
  Bytes b;
  ASSERT_TRUE(encode_append(Envelope{1, 0, Telemetry{}}, b));
  StreamDecoder d;
  StreamDecoder::Outcome o;
  EXPECT_EQ(d.feed(std::span(b).first(b.size() - 1), o), b.size() - 1);
  EXPECT_EQ(o.kind, StreamDecoder::Kind::kNeedMore);
  EXPECT_EQ(d.feed(std::span(b).last(1), o), 1u);
  EXPECT_EQ(o.kind, StreamDecoder::Kind::kMessage);
  EXPECT_EQ(d.feed({}, o), 0u);
  EXPECT_EQ(o.kind, StreamDecoder::Kind::kNeedMore);
}

TEST(Stream, ManyFramesOneOutcomePerCall) {
  Bytes b;
  for (std::uint32_t i = 0; i < 50; ++i)
    ASSERT_TRUE(encode_append(Envelope{i, 0, Ping{i}}, b));
  StreamDecoder d;
  StreamDecoder::Outcome o;
  std::span<const std::uint8_t> in(b);
  std::uint32_t next = 0;
  while (!in.empty()) {
    in = in.subspan(d.feed(in, o));
    ASSERT_EQ(o.kind, StreamDecoder::Kind::kMessage);
    EXPECT_EQ(o.envelope.request_id, next++);
  }
  EXPECT_EQ(next, 50u);
}

// The buffer for a frame split across calls is allocated at the first such frame, not before: a
// peer whose frames arrive whole costs the decoder nothing beyond itself. Every frame decodes the
// same before, at and after the allocation, split in the header or in the payload, whole again
// after it, and after a reset() in the middle of a frame.
TEST(Stream, TheSplitFrameBufferComesWithTheFirstSplitFrameAndEveryFrameStillDecodes) {
  const Bytes once = all_samples_stream(1);
  StreamDecoder d;
  EXPECT_EQ(d.buffer_bytes(), 0u);
  expect_all_samples(feed_all(
                         once, [&] { return once.size(); }, d),
                     1);
  EXPECT_EQ(d.buffer_bytes(), 0u) << "whole frames need no buffer";

  // The largest sample frame, split at every byte: the first split allocates, every split decodes.
  const auto samples = samples::all();
  Bytes frame;
  const Envelope* largest = nullptr;
  for (const auto& sample : samples) {
    Bytes f;
    ASSERT_TRUE(encode_append(sample.envelope, f));
    if (f.size() > frame.size()) {
      frame = f;
      largest = &sample.envelope;
    }
  }
  for (std::size_t cut = 1; cut < frame.size(); ++cut) {
    SCOPED_TRACE(cut);
    StreamDecoder::Outcome o;
    ASSERT_EQ(d.feed(std::span(frame).first(cut), o), cut);
    EXPECT_EQ(o.kind, StreamDecoder::Kind::kNeedMore);
    EXPECT_EQ(d.buffer_bytes(), kMaxFrameSize);
    ASSERT_EQ(d.feed(std::span(frame).subspan(cut), o), frame.size() - cut);
    ASSERT_EQ(o.kind, StreamDecoder::Kind::kMessage);
    EXPECT_TRUE(wire_equal(o.envelope.message, largest->message));
  }
  // Whole frames again (the buffer kept), then split in threes, then half a frame forgotten.
  expect_all_samples(feed_all(
                         once, [&] { return once.size(); }, d),
                     1);
  expect_all_samples(feed_all(
                         once, [] { return std::size_t{3}; }, d),
                     1);
  StreamDecoder::Outcome o;
  EXPECT_EQ(d.feed(std::span(frame).first(frame.size() / 2), o), frame.size() / 2);
  d.reset();
  EXPECT_EQ(d.buffer_bytes(), kMaxFrameSize);
  expect_all_samples(feed_all(
                         once, [] { return std::size_t{5}; }, d),
                     1);
}

}  // namespace
}  // namespace ajar::protocol
