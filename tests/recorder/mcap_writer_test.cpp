// The MCAP writer's bytes against the specification (mcap.dev/spec): magic at both ends, every
// record's opcode and length, the fields of Header, Schema, Channel, Message, Data End,
// Statistics, Summary Offset and Footer at their offsets, and both CRCs recomputed here.
#include "ajar/recorder/mcap_writer.hpp"

#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ajar/recorder/channels.hpp"

namespace ajar::recorder {
namespace {

// A reader of the specification's primitives over a byte span (independent of the writer).
struct Cursor {
  const std::vector<std::uint8_t>& b;
  std::size_t at = 0;
  std::uint64_t le(int n) {
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i)
      v |= std::uint64_t{b.at(at + static_cast<std::size_t>(i))} << (8 * i);
    at += static_cast<std::size_t>(n);
    return v;
  }
  std::string str() {
    const auto n = static_cast<std::size_t>(le(4));
    std::string s(reinterpret_cast<const char*>(b.data() + at), n);
    at += n;
    return s;
  }
};

struct Record {
  std::uint8_t op;
  std::size_t start, content, end;  // offsets: opcode, content, one past
};

std::vector<Record> records(const std::vector<std::uint8_t>& b) {
  std::vector<Record> out;
  Cursor c{b, 8};
  while (c.at < b.size() - 8) {
    Record r{b.at(c.at), c.at, 0, 0};
    c.at += 1;
    const auto len = c.le(8);
    r.content = c.at;
    r.end = c.at + static_cast<std::size_t>(len);
    EXPECT_LE(r.end, b.size() - 8) << "record at " << r.start << " overruns the file";
    c.at = r.end;
    out.push_back(r);
  }
  EXPECT_EQ(c.at, b.size() - 8);
  return out;
}

TEST(Crc32, MatchesTheCheckValueOfCrc32IsoHdlc) {
  const std::string check = "123456789";
  EXPECT_EQ(crc32(std::span(reinterpret_cast<const std::uint8_t*>(check.data()), check.size())),
            0xCBF43926U);
  // Continuing a CRC over two parts is the CRC of the whole.
  const auto* p = reinterpret_cast<const std::uint8_t*>(check.data());
  EXPECT_EQ(crc32(std::span(p + 4, 5), crc32(std::span(p, 4))), 0xCBF43926U);
}

// The data section of the file BytesFollowTheSpecification writes: Header, Schema, Channel,
// Messages (with their sequence per channel), and Data End's CRC.
void expect_data_section(const std::vector<std::uint8_t>& b, const std::vector<Record>& rs) {
  Cursor c{b, rs[0].content};
  EXPECT_EQ(c.str(), "");
  EXPECT_EQ(c.str(), "ajar-test");

  c.at = rs[1].content;
  EXPECT_EQ(c.le(2), 1U);
  EXPECT_EQ(c.str(), "ajar.Event");
  EXPECT_EQ(c.str(), "jsonschema");
  EXPECT_EQ(c.str(), R"({"type":"object"})");
  EXPECT_EQ(c.at, rs[1].end);

  c.at = rs[2].content;
  EXPECT_EQ(c.le(2), 2U);
  EXPECT_EQ(c.le(2), 1U);
  EXPECT_EQ(c.str(), "/ajar/events");
  EXPECT_EQ(c.str(), "json");
  EXPECT_EQ(c.le(4), 10U) << "map byte length: 4+1 + 4+1";
  EXPECT_EQ(c.str(), "k");
  EXPECT_EQ(c.str(), "v");
  EXPECT_EQ(c.at, rs[2].end);

  c.at = rs[4].content;
  EXPECT_EQ(c.le(2), 2U);     // channel
  EXPECT_EQ(c.le(4), 1U);     // sequence
  EXPECT_EQ(c.le(8), 1000U);  // log_time
  EXPECT_EQ(c.le(8), 1000U);  // publish_time
  EXPECT_EQ(std::string(b.begin() + static_cast<std::ptrdiff_t>(c.at),
                        b.begin() + static_cast<std::ptrdiff_t>(rs[4].end)),
            R"({"a":1})");
  c.at = rs[6].content;
  EXPECT_EQ(c.le(2), 2U);
  EXPECT_EQ(c.le(4), 2U) << "sequence counts per channel";

  // Data End: CRC-32 of every byte before it.
  c.at = rs[7].content;
  EXPECT_EQ(c.le(4), crc32(std::span(b.data(), rs[7].start)));
}

// Its summary: Statistics, the Summary Offsets of each group, and the Footer.
void expect_summary_section(const std::vector<std::uint8_t>& b, const std::vector<Record>& rs) {
  // Statistics.
  Cursor c{b, rs[11].content};
  EXPECT_EQ(c.le(8), 3U);     // message_count
  EXPECT_EQ(c.le(2), 1U);     // schema_count
  EXPECT_EQ(c.le(4), 2U);     // channel_count
  EXPECT_EQ(c.le(4), 0U);     // attachments
  EXPECT_EQ(c.le(4), 0U);     // metadata
  EXPECT_EQ(c.le(4), 0U);     // chunks
  EXPECT_EQ(c.le(8), 900U);   // message_start_time
  EXPECT_EQ(c.le(8), 2000U);  // message_end_time
  EXPECT_EQ(c.le(4), 20U);    // map: 2 x (u16 + u64)
  EXPECT_EQ(c.le(2), 1U);
  EXPECT_EQ(c.le(8), 1U);
  EXPECT_EQ(c.le(2), 2U);
  EXPECT_EQ(c.le(8), 2U);

  // Summary Offsets point at each group.
  const std::uint8_t group_ops[] = {0x03, 0x04, 0x0B};
  const std::size_t group_first[] = {8, 9, 11}, group_last[] = {8, 10, 11};
  for (std::size_t g = 0; g < 3; ++g) {
    c.at = rs[12 + g].content;
    EXPECT_EQ(c.le(1), group_ops[g]);
    EXPECT_EQ(c.le(8), rs[group_first[g]].start);
    EXPECT_EQ(c.le(8), rs[group_last[g]].end - rs[group_first[g]].start);
  }

  // Footer: summary_start, summary_offset_start, and the CRC of the summary through the footer's
  // summary_offset_start field.
  c.at = rs[15].content;
  EXPECT_EQ(c.le(8), rs[8].start);
  EXPECT_EQ(c.le(8), rs[12].start);
  const std::size_t crc_end = c.at;
  EXPECT_EQ(c.le(4), crc32(std::span(b.data() + rs[8].start, crc_end - rs[8].start)));
  EXPECT_EQ(c.at, rs[15].end);
}

TEST(McapWriter, BytesFollowTheSpecification) {
  McapWriter w("", "ajar-test");
  w.add_schema(1, "ajar.Event", "jsonschema", R"({"type":"object"})");
  w.add_channel(2, 1, "/ajar/events", "json", {{"k", "v"}});
  w.add_channel(1, 0, "/ajar/wire", "ajar.wire");
  w.add_message(2, 1000, std::string_view(R"({"a":1})"));
  w.add_message(1, 900, std::string_view("\x01\x02", 2));
  w.add_message(2, 2000, std::string_view(R"({"a":2})"));
  w.close();
  const auto b = w.take_bytes();
  ASSERT_GT(b.size(), 16U);
  EXPECT_EQ(std::memcmp(b.data(), kMcapMagic, 8), 0);
  EXPECT_EQ(std::memcmp(b.data() + b.size() - 8, kMcapMagic, 8), 0);
  EXPECT_EQ(b[5], 0x30) << "major version '0'";

  const auto rs = records(b);
  std::vector<std::uint8_t> ops;
  for (const auto& r : rs)
    ops.push_back(r.op);
  // Header, Schema, Channel x2, Message x3, Data End, summary (Schema, Channel x2, Statistics),
  // Summary Offset x3 (one per group), Footer.
  EXPECT_EQ(ops, (std::vector<std::uint8_t>{0x01, 0x03, 0x04, 0x04, 0x05, 0x05, 0x05, 0x0F, 0x03,
                                            0x04, 0x04, 0x0B, 0x0E, 0x0E, 0x0E, 0x02}));
  ASSERT_EQ(rs.size(), ops.size());

  expect_data_section(b, rs);
  expect_summary_section(b, rs);
}

TEST(McapWriter, HandsOutWholeRecordsSoThatEveryTakenPrefixParses) {
  McapWriter w(kMcapProfile, kMcapLibrary);
  w.add_ajar_channels();
  std::vector<std::uint8_t> file = w.take_bytes();
  for (int i = 0; i < 50; ++i) {
    w.add_message(kLoopChannel, static_cast<std::uint64_t>(i), std::string_view("{}"));
    if (i % 7 == 0) {
      const auto part = w.take_bytes();
      file.insert(file.end(), part.begin(), part.end());
      // A prefix of whole records: every record ends inside the file.
      std::vector<std::uint8_t> with_magic = file;
      with_magic.insert(with_magic.end(), std::begin(kMcapMagic), std::end(kMcapMagic));
      const auto rs = records(with_magic);
      ASSERT_FALSE(rs.empty());
      EXPECT_EQ(rs.back().op, 0x05);
    }
  }
  EXPECT_EQ(w.message_count(kLoopChannel), 50U);
  EXPECT_EQ(w.message_count(kWireChannel), 0U);
}

TEST(McapWriter, RefusesWhatTheSpecificationForbids) {
  McapWriter w("", "t");
  EXPECT_THROW(w.add_schema(0, "x", "jsonschema", "{}"), std::invalid_argument);
  EXPECT_THROW(w.add_channel(1, 5, "/x", "json"), std::invalid_argument);  // schema 5 unknown
  EXPECT_THROW(w.add_message(9, 1, std::string_view("{}")), std::invalid_argument);
  w.close();
  EXPECT_THROW(w.add_message(1, 1, std::string_view("{}")), std::logic_error);
}

}  // namespace
}  // namespace ajar::recorder
