// A sequential reader of MCAP files (mcap.dev/spec, major version 0), for ajarctl blackbox/replay
// and the tests: it reads the records from the leading magic on, enters chunks whose records are
// not compressed, and stops cleanly at a truncated tail. A file cut anywhere (kill -9, power loss:
// no Data End, summary or Footer) yields every whole record before the cut; `complete` says
// whether the file ended as the specification says (Data End ... Footer, trailing magic).
// Compressed chunks (lz4, zstd: the recorder writes none) are skipped and counted. Not for the
// daemon's realtime paths (it reads the whole file and allocates).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace ajar::recorder {

struct McapSchema {
  std::uint16_t id = 0;
  std::string name;
  std::string encoding;
  std::string data;
};
struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;
  std::map<std::string, std::string> metadata;
};
struct McapMessage {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time_ns = 0;
  std::uint64_t publish_time_ns = 0;
  std::size_t data_offset = 0;  // into McapFile::bytes
  std::size_t data_size = 0;
};

struct McapFile {
  std::vector<std::uint8_t> bytes;  // the whole file
  bool is_mcap = false;             // it starts with the MCAP magic (else nothing below is read)
  std::string profile, library;     // the Header record
  std::map<std::uint16_t, McapSchema> schemas;
  std::map<std::uint16_t, McapChannel> channels;
  std::vector<McapMessage> messages;  // in file order (chunks entered where they are)
  bool complete = false;              // Data End, Footer and the trailing magic were read
  std::uint64_t read_up_to = 0;       // bytes read as whole records (the file's size when complete)
  std::size_t skipped_chunks = 0;     // compressed chunks (not read)
  std::string problem;                // why reading stopped before the end, for people ("" if not)

  std::span<const std::uint8_t> data(const McapMessage& m) const {
    return {bytes.data() + m.data_offset, m.data_size};
  }
  // The channel of `topic`, or nullptr.
  const McapChannel* channel(std::string_view topic) const;
};

// Parses `bytes` (the whole file, or any prefix of it).
McapFile parse_mcap(std::vector<std::uint8_t> bytes);
// Reads and parses the file at `path`; `error` says why when it cannot be read (then is_mcap is
// false).
McapFile read_mcap(const std::string& path, std::string* error = nullptr);

}  // namespace ajar::recorder
