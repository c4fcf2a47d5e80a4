// The MCAP reader (mcap_reader.hpp), from the specification: records are <opcode u8><length u64>
// <body>; strings are <u32 length><UTF-8>, byte arrays <u32 or u64 length><bytes>, maps
// <u32 byte length><key string><value string>...; all integers little-endian.
#include "ajar/recorder/mcap_reader.hpp"

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

namespace ajar::recorder {

namespace {

constexpr std::array<std::uint8_t, 8> kMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
constexpr std::size_t kRecordHeader = 9;  // opcode + length

enum Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kDataEnd = 0x0F,
};

// Reads the fields of one record body; any read past its end fails the cursor.
class Cursor {
 public:
  Cursor(const std::uint8_t* p, std::size_t size) : p_(p), size_(size) {}
  bool ok() const { return ok_; }
  std::size_t pos() const { return pos_; }
  std::size_t left() const { return size_ - pos_; }
  template <typename T>
  T integer() {
    if (!take(sizeof(T))) return 0;
    T v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i)
      v = static_cast<T>(v | static_cast<T>(static_cast<T>(p_[pos_ - sizeof(T) + i]) << (8 * i)));
    return v;
  }
  std::string string() {
    const auto n = integer<std::uint32_t>();
    if (!take(n)) return {};
    return {reinterpret_cast<const char*>(p_ + pos_ - n), n};
  }
  std::map<std::string, std::string> map() {
    std::map<std::string, std::string> out;
    const auto n = integer<std::uint32_t>();
    if (!ok_ || n > left()) {
      ok_ = false;
      return out;
    }
    Cursor entries(p_ + pos_, n);
    while (entries.ok() && entries.left() > 0) {
      std::string key = entries.string();
      std::string value = entries.string();
      if (entries.ok()) out.emplace(std::move(key), std::move(value));
    }
    ok_ = entries.ok();
    pos_ += n;
    return out;
  }
  bool take(std::uint64_t n) {
    if (!ok_ || n > left()) {
      ok_ = false;
      return false;
    }
    pos_ += static_cast<std::size_t>(n);
    return true;
  }

 private:
  const std::uint8_t* p_;
  std::size_t size_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

std::uint64_t get_u64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i)
    v = (v << 8) | p[i];
  return v;
}

class Parser {
 public:
  explicit Parser(McapFile& f) : f_(f) {}

  void run() {
    const auto& b = f_.bytes;
    if (b.size() < kMagic.size() || !std::equal(kMagic.begin(), kMagic.end(), b.begin())) {
      f_.problem = "not an MCAP file (no MCAP magic at its start)";
      return;
    }
    f_.is_mcap = true;
    f_.read_up_to = kMagic.size();
    records(kMagic.size(), b.size(), false);
  }

 private:
  // The records in [begin, end): the file (top level) or a chunk's records.
  void records(std::size_t begin, std::size_t end, bool in_chunk) {
    std::size_t pos = begin;
    while (pos < end) {
      if (end - pos < kRecordHeader) return cut(pos, in_chunk, "a record header");
      const std::uint8_t op = f_.bytes[pos];
      const std::uint64_t length = get_u64(&f_.bytes[pos + 1]);
      if (length > end - pos - kRecordHeader) return cut(pos, in_chunk, "a record");
      const std::size_t body = pos + kRecordHeader;
      if (!record(op, body, static_cast<std::size_t>(length))) {
        f_.problem =
            "malformed record (opcode " + std::to_string(op) + ") at byte " + std::to_string(pos);
        stopped_ = true;
        return;
      }
      pos = body + static_cast<std::size_t>(length);
      if (!in_chunk) f_.read_up_to = pos;
      if (op == kFooter && !in_chunk) {
        if (f_.bytes.size() - pos >= kMagic.size() &&
            std::equal(kMagic.begin(), kMagic.end(), f_.bytes.begin() + static_cast<long>(pos))) {
          f_.complete = data_end_;
          f_.read_up_to = pos + kMagic.size();
          if (!data_end_) f_.problem = "Footer without Data End";
        } else {
          f_.problem = "no trailing magic after the Footer";
        }
        return;
      }
      if (stopped_) return;
    }
    if (!in_chunk) f_.problem = "the file ends without a Footer (cut short: kill -9 or power loss)";
  }

  void cut(std::size_t pos, bool in_chunk, const char* what) {
    f_.problem = std::string(in_chunk ? "a chunk ends inside " : "the file ends inside ") + what +
                 " at byte " + std::to_string(pos) + " (cut short: kill -9 or power loss)";
    stopped_ = true;
  }

  bool record(std::uint8_t op, std::size_t body, std::size_t length) {
    Cursor c(f_.bytes.data() + body, length);
    switch (op) {
      case kHeader:
        f_.profile = c.string();
        f_.library = c.string();
        return c.ok();
      case kSchema: {
        McapSchema s;
        s.id = c.integer<std::uint16_t>();
        s.name = c.string();
        s.encoding = c.string();
        const auto n = c.integer<std::uint32_t>();
        const std::size_t at = c.pos();
        if (!c.take(n)) return false;
        s.data.assign(reinterpret_cast<const char*>(f_.bytes.data() + body + at), n);
        if (s.id != 0) f_.schemas[s.id] = std::move(s);  // id 0 is invalid: ignored
        return true;
      }
      case kChannel: {
        McapChannel ch;
        ch.id = c.integer<std::uint16_t>();
        ch.schema_id = c.integer<std::uint16_t>();
        ch.topic = c.string();
        ch.message_encoding = c.string();
        ch.metadata = c.map();
        if (!c.ok()) return false;
        f_.channels[ch.id] = std::move(ch);
        return true;
      }
      case kMessage: {
        McapMessage m;
        m.channel_id = c.integer<std::uint16_t>();
        m.sequence = c.integer<std::uint32_t>();
        m.log_time_ns = c.integer<std::uint64_t>();
        m.publish_time_ns = c.integer<std::uint64_t>();
        if (!c.ok()) return false;
        m.data_offset = body + c.pos();
        m.data_size = c.left();
        f_.messages.push_back(m);
        return true;
      }
      case kChunk: {
        c.integer<std::uint64_t>();  // message_start_time
        c.integer<std::uint64_t>();  // message_end_time
        c.integer<std::uint64_t>();  // uncompressed_size
        c.integer<std::uint32_t>();  // uncompressed_crc
        const std::string compression = c.string();
        const auto n = c.integer<std::uint64_t>();
        const std::size_t at = c.pos();
        if (!c.take(n)) return false;
        if (!compression.empty()) {
          ++f_.skipped_chunks;
          return true;
        }
        records(body + at, body + at + static_cast<std::size_t>(n), true);
        return true;
      }
      case kDataEnd:
        data_end_ = true;
        return true;
      default:  // Footer (handled by the caller), indexes, statistics, attachments, metadata
        return true;
    }
  }

  McapFile& f_;
  bool data_end_ = false;
  bool stopped_ = false;
};

}  // namespace

const McapChannel* McapFile::channel(std::string_view topic) const {
  for (const auto& [id, ch] : channels) {
    if (ch.topic == topic) return &ch;
  }
  return nullptr;
}

McapFile parse_mcap(std::vector<std::uint8_t> bytes) {
  McapFile f;
  f.bytes = std::move(bytes);
  Parser(f).run();
  return f;
}

McapFile read_mcap(const std::string& path, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error != nullptr) *error = "cannot read " + path + ": " + std::strerror(errno);
    McapFile f;
    f.problem = "cannot read " + path;
    return f;
  }
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  McapFile f = parse_mcap(std::move(bytes));
  if (!f.is_mcap && error != nullptr) *error = path + ": " + f.problem;
  return f;
}

}  // namespace ajar::recorder
