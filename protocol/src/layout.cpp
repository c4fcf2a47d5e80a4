// payload_layout(): the message tables walked by a lister instead of a writer.
#include "ajar/protocol/layout.hpp"

#include <algorithm>

#include "ajar/protocol/codec.hpp"
#include "walk.hpp"

namespace ajar::protocol {

using namespace detail;

namespace {

template <std::size_t N>
constexpr auto decimal_text() {
  if constexpr (N < 10) {
    Text<2> t;
    t.chars = {static_cast<char>('0' + N), '\0'};
    return t;
  } else {
    return decimal_text<N / 10>() + decimal_text<N % 10>();
  }
}

class Lister {
 public:
  // Reserved up front: the walk is noexcept and a payload has at most kMaxPayloadSize fields.
  explicit Lister(std::uint8_t minor) : minor_(minor) { rows_.reserve(kMaxPayloadSize); }
  bool since(std::uint8_t m) noexcept {
    since_ = std::max(since_, m);  // appended fields come last: the walk's since only grows
    return minor_ >= m;
  }
  template <typename T>
  void u8(T, const char* f) {
    add(1, "u8", f);
  }
  template <typename T>
  void u16(T, const char* f) {
    add(2, "u16", f);
  }
  template <typename T>
  void u32(T, const char* f) {
    add(4, "u32", f);
  }
  template <typename T>
  void u64(T, const char* f) {
    add(8, "u64", f);
  }
  template <typename T>
  void i64(T, const char* f) {
    add(8, "i64", f);
  }
  template <typename T>
  void f32(T, const char* f) {
    add(4, "f32", f);
  }
  template <typename T>
  void f64(T, const char* f) {
    add(8, "f64", f);
  }
  template <typename T>
  void boolean(T, const char* f) {
    add(1, "bool", f);
  }
  template <typename T>
  void polarity(T, const char* f) {
    add(1, "i8", f);
  }
  template <typename E>
  void enumeration(E, const char* f, std::uint8_t) {
    add(1, "u8", f);
  }
  void error_code(ErrorCode, const char* f) { add(2, "u16", f); }
  void raw_type(MessageType, const char* f) { add(2, "u16", f); }
  template <std::size_t N>
  void str(const FixedString<N>&, const char* f) {
    add(1 + N, c_str<Text("str<") + decimal_text<N>() + Text(">")>(), f);
  }
  bool plane_count(std::uint8_t count, const char* f) {
    add(1, "u8", f);
    if (count < kMinPlanePoints || count > kMaxPlanePoints) ok_ = false;
    return ok_;
  }
  bool ack_type(MessageType t, const char* f) {
    add(2, "u16", f);
    if (!is_request(t) || minor_of(t) > minor_) ok_ = false;
    return ok_;
  }
  template <typename T>
  const T* body(const AckBody& b) {
    const T* p = std::get_if<T>(&b);
    if (p == nullptr) ok_ = false;
    return p;
  }
  std::vector<FieldLayout> rows() && {
    if (!ok_) rows_.clear();
    return std::move(rows_);
  }

 private:
  void add(std::size_t size, std::string_view type, const char* name) {
    rows_.push_back({offset_, size, type, name, since_});
    offset_ += size;
  }
  std::uint8_t minor_;
  std::uint8_t since_ = 0;
  std::size_t offset_ = 0;
  bool ok_ = true;
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
