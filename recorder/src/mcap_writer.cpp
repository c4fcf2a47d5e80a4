// McapWriter (mcap_writer.hpp): record layouts from the MCAP specification, field by field.
#include "ajar/recorder/mcap_writer.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>

#include "ajar/recorder/channels.hpp"

namespace ajar::recorder {
namespace {

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k)
      c = (c & 1U) != 0 ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr auto kCrcTable = make_crc_table();

void u8(std::vector<std::uint8_t>& out, std::uint8_t v) {
  out.push_back(v);
}
void u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  for (int i = 0; i < 2; ++i)
    out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void u64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i)
    out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put_u32_at(std::vector<std::uint8_t>& out, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i)
    out[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_u64_at(std::vector<std::uint8_t>& out, std::size_t at, std::uint64_t v) {
  for (std::size_t i = 0; i < 8; ++i)
    out[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void bytes(std::vector<std::uint8_t>& out, std::string_view s) {
  out.insert(out.end(), s.begin(), s.end());
}
void string(std::vector<std::uint8_t>& out, std::string_view s) {
  u32(out, static_cast<std::uint32_t>(s.size()));
  bytes(out, s);
}
// Opens a record: opcode and a length to be patched by end_record(); returns where it starts.
std::size_t begin_record(std::vector<std::uint8_t>& out, McapOp op) {
  const std::size_t at = out.size();
  u8(out, static_cast<std::uint8_t>(op));
  u64(out, 0);
  return at;
}
void end_record(std::vector<std::uint8_t>& out, std::size_t at) {
  put_u64_at(out, at + 1, out.size() - at - 9);
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> data, std::uint32_t crc) noexcept {
  crc = ~crc;
  for (const std::uint8_t b : data)
    crc = kCrcTable[(crc ^ b) & 0xFFU] ^ (crc >> 8);
  return ~crc;
}

McapWriter::McapWriter(std::string_view profile, std::string_view library) {
  scratch_.assign(std::begin(kMcapMagic), std::end(kMcapMagic));
  const std::size_t at = begin_record(scratch_, McapOp::kHeader);
  string(scratch_, profile);
  string(scratch_, library);
  end_record(scratch_, at);
  emit(scratch_);
}

void McapWriter::emit(std::span<const std::uint8_t> record) {
  buffer_.insert(buffer_.end(), record.begin(), record.end());
  data_crc_ = crc32(record, data_crc_);
  offset_ += record.size();
}

void McapWriter::schema_record(std::vector<std::uint8_t>& out, const Schema& s) {
  const std::size_t at = begin_record(out, McapOp::kSchema);
  u16(out, s.id);
  string(out, s.name);
  string(out, s.encoding);
  string(out, s.data);  // uint32 length-prefixed bytes: the same layout as a string
  end_record(out, at);
}

void McapWriter::channel_record(std::vector<std::uint8_t>& out, const Channel& c) {
  const std::size_t at = begin_record(out, McapOp::kChannel);
  u16(out, c.id);
  u16(out, c.schema_id);
  string(out, c.topic);
  string(out, c.encoding);
  const std::size_t map_at = out.size();
  u32(out, 0);
  for (const auto& [key, value] : c.metadata) {
    string(out, key);
    string(out, value);
  }
  put_u32_at(out, map_at, static_cast<std::uint32_t>(out.size() - map_at - 4));
  end_record(out, at);
}

void McapWriter::add_schema(std::uint16_t id, std::string_view name, std::string_view encoding,
                            std::string_view data) {
  if (id == 0) throw std::invalid_argument("MCAP schema id 0 is reserved");
  if (closed_) throw std::logic_error("MCAP writer closed");
  schemas_.push_back({id, std::string(name), std::string(encoding), std::string(data)});
  scratch_.clear();
  schema_record(scratch_, schemas_.back());
  emit(scratch_);
}

void McapWriter::add_channel(std::uint16_t id, std::uint16_t schema_id, std::string_view topic,
                             std::string_view message_encoding,
                             const std::vector<std::pair<std::string, std::string>>& metadata) {
  if (closed_) throw std::logic_error("MCAP writer closed");
  if (schema_id != 0 && std::none_of(schemas_.begin(), schemas_.end(),
                                     [&](const Schema& s) { return s.id == schema_id; })) {
    throw std::invalid_argument("MCAP channel before its schema");
  }
  channels_.push_back({id, schema_id, std::string(topic), std::string(message_encoding), metadata});
  counts_[id];  // a channel without messages counts 0 in Statistics
  scratch_.clear();
  channel_record(scratch_, channels_.back());
  emit(scratch_);
}

void McapWriter::add_ajar_channels() {
  for (const auto& c : kChannels) {
    if (c.schema_id != 0) add_schema(c.schema_id, c.schema_name, c.schema_encoding, c.schema);
  }
  for (const auto& c : kChannels) {
    std::vector<std::pair<std::string, std::string>> metadata;
    if (c.message_encoding == "ajar.wire")
      metadata.emplace_back("layout", std::string(kWireLayout));
    add_channel(c.id, c.schema_id, c.topic, c.message_encoding, metadata);
  }
}

void McapWriter::add_message(std::uint16_t channel, std::uint64_t time_ns,
                             std::span<const std::uint8_t> data) {
  add_message(channel, time_ns, {}, data);
}

void McapWriter::add_message(std::uint16_t channel, std::uint64_t time_ns,
                             std::span<const std::uint8_t> head,
                             std::span<const std::uint8_t> data) {
  if (closed_) throw std::logic_error("MCAP writer closed");
  const auto count = counts_.find(channel);
  if (count == counts_.end()) throw std::invalid_argument("MCAP message on an unknown channel");
  scratch_.clear();
  const std::size_t at = begin_record(scratch_, McapOp::kMessage);
  u16(scratch_, channel);
  u32(scratch_, ++sequences_[channel]);
  u64(scratch_, time_ns);  // log_time
  u64(scratch_, time_ns);  // publish_time
  scratch_.insert(scratch_.end(), head.begin(), head.end());
  scratch_.insert(scratch_.end(), data.begin(), data.end());
  end_record(scratch_, at);
  emit(scratch_);
  ++count->second;
  if (message_count_ == 0 || time_ns < first_time_ns_) first_time_ns_ = time_ns;
  if (message_count_ == 0 || time_ns > last_time_ns_) last_time_ns_ = time_ns;
  ++message_count_;
}

void McapWriter::add_message(std::uint16_t channel, std::uint64_t time_ns, std::string_view data) {
  add_message(channel, time_ns,
              std::span(reinterpret_cast<const std::uint8_t*>(data.data()), data.size()));
}

std::uint64_t McapWriter::message_count(std::uint16_t channel) const {
  const auto it = counts_.find(channel);
  return it == counts_.end() ? 0 : it->second;
}

void McapWriter::close() {
  if (closed_) return;
  scratch_.clear();
  std::size_t at = begin_record(scratch_, McapOp::kDataEnd);
  u32(scratch_, data_crc_);  // every byte before this record
  end_record(scratch_, at);

  // Summary: groups by opcode (Schema, Channel, Statistics), then one Summary Offset per group.
  const std::uint64_t summary_start = offset_ + scratch_.size();
  struct Group {
    McapOp op;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  const auto group = [&](McapOp op, auto&& body) {
    const std::size_t begin = scratch_.size();
    body();
    if (scratch_.size() > begin) {
      groups.push_back({op, offset_ + begin, scratch_.size() - begin});
    }
  };
  group(McapOp::kSchema, [&] {
    for (const auto& s : schemas_)
      schema_record(scratch_, s);
  });
  group(McapOp::kChannel, [&] {
    for (const auto& c : channels_)
      channel_record(scratch_, c);
  });
  group(McapOp::kStatistics, [&] {
    at = begin_record(scratch_, McapOp::kStatistics);
    u64(scratch_, message_count_);
    u16(scratch_, static_cast<std::uint16_t>(schemas_.size()));
    u32(scratch_, static_cast<std::uint32_t>(channels_.size()));
    u32(scratch_, 0);  // attachment_count
    u32(scratch_, 0);  // metadata_count
    u32(scratch_, 0);  // chunk_count
    u64(scratch_, message_count_ == 0 ? 0 : first_time_ns_);
    u64(scratch_, message_count_ == 0 ? 0 : last_time_ns_);
    const std::size_t map_at = scratch_.size();
    u32(scratch_, 0);
    for (const auto& [channel, count] : counts_) {
      u16(scratch_, channel);
      u64(scratch_, count);
    }
    put_u32_at(scratch_, map_at, static_cast<std::uint32_t>(scratch_.size() - map_at - 4));
    end_record(scratch_, at);
  });
  const std::uint64_t summary_offset_start = offset_ + scratch_.size();
  for (const auto& g : groups) {
    at = begin_record(scratch_, McapOp::kSummaryOffset);
    u8(scratch_, static_cast<std::uint8_t>(g.op));
    u64(scratch_, g.start);
    u64(scratch_, g.length);
    end_record(scratch_, at);
  }
  // Footer: its CRC covers the summary section through summary_offset_start.
  at = begin_record(scratch_, McapOp::kFooter);
  u64(scratch_, summary_start);
  u64(scratch_, summary_offset_start);
  put_u64_at(scratch_, at + 1, 8 + 8 + 4);  // the length is covered by the CRC: set it first
  const std::size_t summary_begin = static_cast<std::size_t>(summary_start - offset_);
  const std::uint32_t summary_crc =
      crc32(std::span(scratch_).subspan(summary_begin, scratch_.size() - summary_begin));
  u32(scratch_, summary_crc);
  end_record(scratch_, at);
  scratch_.insert(scratch_.end(), std::begin(kMcapMagic), std::end(kMcapMagic));
  emit(scratch_);
  closed_ = true;
}

std::vector<std::uint8_t> McapWriter::take_bytes() {
  std::vector<std::uint8_t> out;
  out.swap(buffer_);
  return out;
}

}  // namespace ajar::recorder
