// McapWriter: MCAP records into memory, written from the specification (mcap.dev/spec, major
// version 0; docs/blackbox.md, "File layout"). The caller moves the bytes to the file
// (take_bytes()) whenever it likes: every byte handed out ends on a record boundary, so a file cut
// anywhere after a handed-out boundary is a valid MCAP prefix that a streaming reader reads up to
// that record (no footer needed).
//
// Layout (no chunks: every record sits in the data section as it comes, so a crash loses only
// what was not yet written; no compression, so no dependency):
//   <magic><Header><Schema...><Channel...><Message|Schema|Channel...>
//   close(): <Data End: CRC-32 of every byte before it>
//            <summary: Schema group, Channel group, Statistics><Summary Offset per group>
//            <Footer: summary_start, summary_offset_start, summary CRC-32><magic>
// Integers little-endian; strings u32 length + UTF-8; maps u32 byte length + entries.
// CRC-32 is the one of zlib/PNG/Ethernet (reflected 0xEDB88320, init and final xor 0xFFFFFFFF), as
// the specification asks. Not thread-safe: one writer thread owns it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ajar::recorder {

inline constexpr std::uint8_t kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};

// MCAP record opcodes (the specification's "Records").
enum class McapOp : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// CRC-32 (ISO-HDLC) of `bytes`, continuing from `crc` (0 for a fresh one).
std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0) noexcept;

class McapWriter {
 public:
  // Starts a file: magic and Header(profile, library).
  McapWriter(std::string_view profile, std::string_view library);

  // Schema ids must not be 0; a channel's schema (0: none) must have been added first.
  void add_schema(std::uint16_t id, std::string_view name, std::string_view encoding,
                  std::string_view data);
  void add_channel(std::uint16_t id, std::uint16_t schema_id, std::string_view topic,
                   std::string_view message_encoding,
                   const std::vector<std::pair<std::string, std::string>>& metadata = {});
  // Every row of channels.hpp (its schemas, then its channels).
  void add_ajar_channels();
  // A Message on `channel` (added before): log_time = publish_time = `time_ns`; its sequence
  // counts per channel from 1.
  void add_message(std::uint16_t channel, std::uint64_t time_ns,
                   std::span<const std::uint8_t> data);
  // The same with the message's data in two parts, `head` then `data` (a wire record's header and
  // the frame, kept apart by the caller).
  void add_message(std::uint16_t channel, std::uint64_t time_ns, std::span<const std::uint8_t> head,
                   std::span<const std::uint8_t> data);
  void add_message(std::uint16_t channel, std::uint64_t time_ns, std::string_view data);

  // Ends the file: Data End, summary, summary offsets, Footer, magic. Nothing may follow.
  void close();
  bool closed() const noexcept { return closed_; }

  // The bytes made since the last call (whole records); they count as written from now on.
  std::vector<std::uint8_t> take_bytes();
  // The bytes made since the last take_bytes()/clear_pending() (whole records), for a caller that
  // writes them from here and then clears them: the buffer keeps its capacity (no allocation per
  // write once it has grown, or reserve()d, to the size the caller writes at).
  const std::vector<std::uint8_t>& pending() const noexcept { return buffer_; }
  void clear_pending() noexcept { buffer_.clear(); }
  void reserve(std::size_t bytes) { buffer_.reserve(bytes); }
  std::uint64_t offset() const noexcept { return offset_; }  // total bytes made so far
  std::uint64_t message_count() const noexcept { return message_count_; }
  std::uint64_t message_count(std::uint16_t channel) const;

 private:
  struct Schema {
    std::uint16_t id;
    std::string name, encoding, data;
  };
  struct Channel {
    std::uint16_t id, schema_id;
    std::string topic, encoding;
    std::vector<std::pair<std::string, std::string>> metadata;
  };
  // Record encoders: append one whole record to `out`.
  static void schema_record(std::vector<std::uint8_t>& out, const Schema& s);
  static void channel_record(std::vector<std::uint8_t>& out, const Channel& c);
  void emit(std::span<const std::uint8_t> record);  // into buffer_, CRC, offset

  std::vector<std::uint8_t> buffer_;
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;
  bool closed_ = false;
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::map<std::uint16_t, std::uint64_t> counts_;  // per channel
  std::map<std::uint16_t, std::uint32_t> sequences_;
  std::uint64_t message_count_ = 0;
  std::uint64_t first_time_ns_ = 0, last_time_ns_ = 0;
  std::vector<std::uint8_t> scratch_;
};

}  // namespace ajar::recorder
