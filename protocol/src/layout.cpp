// payload_layout(): the message tables walked by a Writer that also lists what it writes.
#include "ajar/protocol/layout.hpp"

#include <algorithm>

#include "ajar/protocol/codec.hpp"
#include "field_io.hpp"
#include "walk.hpp"

namespace ajar::protocol {

using namespace detail;

namespace {

struct Scratch {
  std::array<std::uint8_t, kMaxPayloadSize> bytes{};
};

class Lister : Scratch, public Writer {
 public:
  // Reserved up front: the walk is noexcept and a payload has at most kMaxPayloadSize fields.
  explicit Lister(std::uint8_t minor) : Writer(Scratch::bytes.data(), kMaxPayloadSize, minor) {
    rows_.reserve(kMaxPayloadSize);
  }
  bool since(std::uint8_t m) noexcept {
    since_ = std::max(since_, m);  // appended fields come last: along a walk, since only grows
    return Writer::since(m);
  }
  template <typename W, typename V>
  void scalar(const V& v, const char* f) noexcept {
    add(sizeof(typename W::raw), W::name.view(), f);
    Writer::scalar<W>(v, f);
  }
  template <std::size_t N>
  void str(const FixedString<N>& s, const char* f) noexcept {
    add(1 + N, kStrName<N>.view(), f);
    Writer::str(s, f);
  }
  template <std::size_t N>
  void bytes(const FixedBytes<N>& b, const char* f) noexcept {
    add(2 + N, kBytesName<N>.view(), f);
    Writer::bytes(b, f);
  }
  std::vector<FieldLayout> rows() && {
    if (!ok()) rows_.clear();
    return std::move(rows_);
  }

 private:
  template <std::size_t N>
  static constexpr auto kStrName = Text("str<") + decimal_text<N>() + Text(">");
  template <std::size_t N>
  static constexpr auto kBytesName = Text("bytes<") + decimal_text<N>() + Text(">");
  void add(std::size_t size, std::string_view type, const char* name) noexcept {
    if (rows_.size() < rows_.capacity())
      rows_.push_back({Writer::size(), size, type, name, since_});
  }
  std::uint8_t since_ = 0;
  std::vector<FieldLayout> rows_;
};

}  // namespace

std::vector<FieldLayout> payload_layout(const Message& m, std::uint8_t minor) {
  if (minor > kVersionMinor || minor_of(type_of(m)) > minor) return {};
  Lister lister(minor);
  std::visit([&lister](const auto& v) { walk<Text("")>(lister, v); }, m);
  return std::move(lister).rows();
}

std::ptrdiff_t offset_of(const Message& m, std::string_view name, std::uint8_t minor) {
  for (const FieldLayout& f : payload_layout(m, minor)) {
    if (f.name == name) return static_cast<std::ptrdiff_t>(f.offset);
  }
  return -1;
}

}  // namespace ajar::protocol
