// The MCAP reader (mcap_reader.hpp) against the recorder's writer and hand-made records: a whole
// file reads back exactly (schemas, channels, messages); a file cut at EVERY byte offset (a
// simulated kill -9) yields exactly the messages whose records ended before the cut; a chunk is
// entered when uncompressed and skipped (counted) when compressed; garbage is refused.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ajar/recorder/channels.hpp"
#include "ajar/recorder/mcap_reader.hpp"
#include "ajar/recorder/mcap_writer.hpp"

namespace ajar::recorder {
namespace {

using Bytes = std::vector<std::uint8_t>;

struct Written {
  Bytes bytes;
  std::vector<std::uint64_t> message_ends;  // file offset where each message's record ends
  std::vector<std::string> payloads;
};

Written write_sample(bool close) {
  Written w;
  McapWriter writer(kMcapProfile, kMcapLibrary);
  writer.add_ajar_channels();
  for (std::size_t i = 0; i < 40; ++i) {
    const std::uint16_t channel = static_cast<std::uint16_t>(1 + i % kChannels.size());
    std::string payload = channel == kWireChannel
                              ? std::string(18 + i, static_cast<char>(i))
                              : "{\"daemon_time_ns\":" + std::to_string(i) + "}";
    writer.add_message(channel, 1000000000ULL + i * 1000, payload);
    w.message_ends.push_back(writer.offset());
    w.payloads.push_back(std::move(payload));
  }
  if (close) writer.close();
  w.bytes = writer.take_bytes();
  return w;
}

std::string text(const McapFile& f, const McapMessage& m) {
  const auto d = f.data(m);
  return {d.begin(), d.end()};
}

TEST(McapReader, AWholeFileReadsBackExactly) {
  const Written w = write_sample(true);
  const McapFile f = parse_mcap(w.bytes);
  ASSERT_TRUE(f.is_mcap);
  EXPECT_TRUE(f.complete) << f.problem;
  EXPECT_EQ(f.read_up_to, w.bytes.size());
  EXPECT_EQ(f.library, kMcapLibrary);
  ASSERT_EQ(f.channels.size(), kChannels.size());
  for (const auto& row : kChannels) {
    const McapChannel* ch = f.channel(row.topic);
    ASSERT_NE(ch, nullptr) << row.topic;
    EXPECT_EQ(ch->id, row.id);
    EXPECT_EQ(ch->message_encoding, row.message_encoding);
    EXPECT_EQ(ch->schema_id, row.schema_id);
    if (row.schema_id != 0) {
      ASSERT_TRUE(f.schemas.count(row.schema_id)) << row.topic;
      EXPECT_EQ(f.schemas.at(row.schema_id).data, row.schema);
      EXPECT_EQ(f.schemas.at(row.schema_id).encoding, row.schema_encoding);
    }
  }
  ASSERT_EQ(f.messages.size(), w.payloads.size());
  for (std::size_t i = 0; i < w.payloads.size(); ++i) {
    EXPECT_EQ(text(f, f.messages[i]), w.payloads[i]) << i;
    EXPECT_EQ(f.messages[i].log_time_ns, 1000000000ULL + i * 1000) << i;
  }
}

// Every cut: exactly the messages whose records ended at or before it, with their bytes.
TEST(McapReader, AFileCutAtAnyByteYieldsEveryMessageBeforeTheCut) {
  for (const bool closed : {false, true}) {
    const Written w = write_sample(closed);
    for (std::size_t cut = 0; cut <= w.bytes.size(); ++cut) {
      const McapFile f =
          parse_mcap(Bytes(w.bytes.begin(), w.bytes.begin() + static_cast<long>(cut)));
      std::size_t expected = 0;
      while (expected < w.message_ends.size() && w.message_ends[expected] <= cut)
        ++expected;
      ASSERT_EQ(f.is_mcap, cut >= 8) << cut;
      ASSERT_EQ(f.messages.size(), expected) << "cut at " << cut << ": " << f.problem;
      for (std::size_t i = 0; i < expected; ++i)
        ASSERT_EQ(text(f, f.messages[i]), w.payloads[i]) << "cut at " << cut;
      EXPECT_EQ(f.complete, closed && cut == w.bytes.size()) << cut;
      if (!f.complete) {
        EXPECT_FALSE(f.problem.empty()) << cut;
      }
      EXPECT_LE(f.read_up_to, cut);
    }
  }
}

void put_u16(Bytes& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}
void put_u32(Bytes& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put_u64(Bytes& b, std::uint64_t v) {
  for (int i = 0; i < 8; ++i)
    b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put_str(Bytes& b, std::string_view s) {
  put_u32(b, static_cast<std::uint32_t>(s.size()));
  b.insert(b.end(), s.begin(), s.end());
}
void record(Bytes& out, std::uint8_t op, const Bytes& body) {
  out.push_back(op);
  put_u64(out, body.size());
  out.insert(out.end(), body.begin(), body.end());
}
Bytes message_record(std::uint16_t channel, std::string_view data) {
  Bytes body;
  put_u16(body, channel);
  put_u32(body, 1);
  put_u64(body, 5);
  put_u64(body, 5);
  body.insert(body.end(), data.begin(), data.end());
  Bytes r;
  record(r, 0x05, body);
  return r;
}

TEST(McapReader, ChunksAreEnteredUnlessCompressed) {
  Bytes file(std::begin(kMcapMagic), std::end(kMcapMagic));
  Bytes header;
  put_str(header, "");
  put_str(header, "hand");
  record(file, 0x01, header);
  Bytes channel;
  put_u16(channel, 1);
  put_u16(channel, 0);
  put_str(channel, "/t");
  put_str(channel, "raw");
  put_u32(channel, 0);  // empty metadata map
  for (const char* compression : {"", "zstd"}) {
    Bytes records;
    record(records, 0x04, channel);
    const Bytes m1 = message_record(1, "in a chunk");
    records.insert(records.end(), m1.begin(), m1.end());
    Bytes chunk;
    put_u64(chunk, 5);
    put_u64(chunk, 5);
    put_u64(chunk, records.size());
    put_u32(chunk, 0);
    put_str(chunk, compression);
    put_u64(chunk, records.size());
    chunk.insert(chunk.end(), records.begin(), records.end());
    record(file, 0x06, chunk);
  }
  const Bytes after = message_record(1, "after");
  file.insert(file.end(), after.begin(), after.end());
  const McapFile f = parse_mcap(file);
  ASSERT_TRUE(f.is_mcap);
  EXPECT_EQ(f.library, "hand");
  EXPECT_EQ(f.skipped_chunks, 1U);
  ASSERT_EQ(f.messages.size(), 2U) << f.problem;
  EXPECT_EQ(text(f, f.messages[0]), "in a chunk");
  EXPECT_EQ(text(f, f.messages[1]), "after");
  ASSERT_NE(f.channel("/t"), nullptr);
  EXPECT_FALSE(f.complete);  // no footer
}

TEST(McapReader, GarbageAndMalformedRecordsAreRefused) {
  const McapFile not_mcap = parse_mcap(Bytes{'A', 'J', 'A', 'R', 1, 2, 3, 4, 5, 6});
  EXPECT_FALSE(not_mcap.is_mcap);
  EXPECT_NE(not_mcap.problem.find("not an MCAP"), std::string::npos);
  // A Channel whose topic string claims more bytes than its record holds: reading stops there.
  Bytes file(std::begin(kMcapMagic), std::end(kMcapMagic));
  const Bytes good = message_record(1, "kept");
  Bytes channel;
  put_u16(channel, 1);
  put_u16(channel, 0);
  put_u32(channel, 1000);
  record(file, 0x04, channel);
  file.insert(file.end(), good.begin(), good.end());
  const McapFile f = parse_mcap(file);
  EXPECT_TRUE(f.is_mcap);
  EXPECT_TRUE(f.messages.empty());
  EXPECT_NE(f.problem.find("malformed record"), std::string::npos) << f.problem;
  std::string error;
  EXPECT_FALSE(read_mcap("/nonexistent/x.mcap", &error).is_mcap);
  EXPECT_NE(error.find("cannot read"), std::string::npos);
}

}  // namespace
}  // namespace ajar::recorder
