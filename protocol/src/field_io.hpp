// The two ends of a payload: the Writer (message -> bytes) and the Reader (bytes -> message, with
// every check of docs/protocol.md section 3). walk.hpp drives both along the same message tables,
// so they cannot disagree; this file says only how each wire type is written, read and checked.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <span>

#include "ajar/protocol/codec.hpp"
#include "little_endian.hpp"

namespace ajar::protocol::detail {

// ---- Writer: message -> payload bytes ---------------------------------------------------------

class Writer {
 public:
  Writer(std::uint8_t* out, std::size_t capacity, std::uint8_t minor) noexcept
      : p_(out), cap_(capacity), minor_(minor) {}
  bool ok() const noexcept { return ok_; }
  // True when the layout being written has the fields that minor version `m` appended.
  bool since(std::uint8_t m) const noexcept { return minor_ >= m; }
  std::size_t size() const noexcept { return pos_; }

  void u8(std::uint8_t v, const char*) noexcept {
    if (std::uint8_t* q = take(1)) q[0] = v;
  }
  void u16(std::uint16_t v, const char*) noexcept {
    if (std::uint8_t* q = take(2)) put_u16(q, v);
  }
  void u32(std::uint32_t v, const char*) noexcept {
    if (std::uint8_t* q = take(4)) put_u32(q, v);
  }
  void u64(std::uint64_t v, const char*) noexcept {
    if (std::uint8_t* q = take(8)) put_u64(q, v);
  }
  void i64(std::int64_t v, const char* f) noexcept { u64(static_cast<std::uint64_t>(v), f); }
  void f32(float v, const char* f) noexcept { u32(std::bit_cast<std::uint32_t>(v), f); }
  void f64(double v, const char* f) noexcept { u64(std::bit_cast<std::uint64_t>(v), f); }
  void boolean(bool v, const char* f) noexcept { u8(v ? 1 : 0, f); }
  void polarity(std::int8_t v, const char* f) noexcept { u8(static_cast<std::uint8_t>(v), f); }
  template <typename E>
  void enumeration(E v, const char* f, std::uint8_t) noexcept {
    u8(static_cast<std::uint8_t>(v), f);
  }
  void error_code(ErrorCode v, const char* f) noexcept { u16(static_cast<std::uint16_t>(v), f); }
  void raw_type(MessageType v, const char* f) noexcept { u16(static_cast<std::uint16_t>(v), f); }
  template <std::size_t N>
  void str(const FixedString<N>& s, const char*) noexcept {
    std::uint8_t* q = take(1 + N);
    if (q == nullptr) return;
    const std::size_t n = std::min<std::size_t>(s.length, N);
    q[0] = static_cast<std::uint8_t>(n);
    std::memcpy(q + 1, s.bytes.data(), n);
    std::memset(q + 1 + n, 0, N - n);
  }
  // Fields that size the payload: the writer refuses values the reader would refuse.
  bool plane_count(std::uint8_t count, const char* f) noexcept {
    if (count < kMinPlanePoints || count > kMaxPlanePoints) ok_ = false;
    u8(count, f);
    return ok_;
  }
  bool ack_type(MessageType t, const char* f) noexcept {
    if (!is_request(t) || minor_of(t) > minor_) ok_ = false;
    raw_type(t, f);
    return ok_;
  }
  template <typename T>
  const T* body(const AckBody& b) noexcept {
    const T* p = std::get_if<T>(&b);
    if (p == nullptr) ok_ = false;
    return p;
  }

 private:
  std::uint8_t* take(std::size_t n) noexcept {
    if (!ok_ || cap_ - pos_ < n) {
      ok_ = false;
      return nullptr;
    }
    std::uint8_t* q = p_ + pos_;
    pos_ += n;
    return q;
  }
  std::uint8_t* p_;
  std::size_t cap_;
  std::uint8_t minor_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

// ---- Reader: payload bytes -> message, with validation ----------------------------------------

constexpr std::array<std::uint8_t, 8> kZeros{};

class Reader {
 public:
  Reader(std::span<const std::uint8_t> payload, std::uint8_t minor) noexcept
      : p_(payload.data()), size_(payload.size()), minor_(minor) {}
  bool since(std::uint8_t m) const noexcept { return minor_ >= m; }

  void u8(std::uint8_t& v, const char*) noexcept { v = take(1)[0]; }
  void u16(std::uint16_t& v, const char*) noexcept { v = get_u16(take(2)); }
  void u32(std::uint32_t& v, const char*) noexcept { v = get_u32(take(4)); }
  void u64(std::uint64_t& v, const char*) noexcept { v = get_u64(take(8)); }
  void i64(std::int64_t& v, const char*) noexcept {
    v = static_cast<std::int64_t>(get_u64(take(8)));
  }
  void f32(float& v, const char* f) noexcept {
    v = std::bit_cast<float>(get_u32(take(4)));
    if (!std::isfinite(v)) fail(ErrorCode::kNonFiniteNumber, f, std::bit_cast<std::uint32_t>(v), 4);
  }
  void f64(double& v, const char* f) noexcept {
    v = std::bit_cast<double>(get_u64(take(8)));
    if (!std::isfinite(v)) fail(ErrorCode::kNonFiniteNumber, f, std::bit_cast<std::uint64_t>(v), 8);
  }
  void boolean(bool& v, const char* f) noexcept {
    const std::uint8_t raw = take(1)[0];
    if (raw > 1) fail(ErrorCode::kInvalidEnumValue, f, raw, 2, "bool");
    v = raw != 0;
  }
  // +1 or -1 as a signed byte.
  void polarity(std::int8_t& v, const char* f) noexcept {
    const std::uint8_t raw = take(1)[0];
    v = static_cast<std::int8_t>(raw);
    if (v != 1 && v != -1) fail(ErrorCode::kInvalidEnumValue, f, raw, 0, "polarity");
  }
  template <typename E>
  void enumeration(E& v, const char* f, std::uint8_t count) noexcept {
    const std::uint8_t raw = take(1)[0];
    if (raw >= count) fail(ErrorCode::kInvalidEnumValue, f, raw, count);
    v = static_cast<E>(raw);
  }
  // Error codes and raw message types are not validated: newer peers may send codes this version
  // does not know (clients treat unknown codes as a generic failure).
  void error_code(ErrorCode& v, const char*) noexcept {
    v = static_cast<ErrorCode>(get_u16(take(2)));
  }
  void raw_type(MessageType& v, const char*) noexcept {
    v = static_cast<MessageType>(get_u16(take(2)));
  }
  template <std::size_t N>
  void str(FixedString<N>& s, const char* f) noexcept {
    const std::uint8_t* q = take_block(1 + N);
    if (q == nullptr) return;
    const std::uint8_t n = q[0];
    if (n > N) {
      fail(ErrorCode::kBadString, f, n, N, "length above capacity");
      return;
    }
    std::memcpy(s.bytes.data(), q + 1, N);
    s.length = n;
    // Branch-free scans (vectorized): padding must be zero; printable ASCII needs no UTF-8 pass.
    std::uint8_t padding = 0;
    for (std::size_t i = n; i < N; ++i)
      padding |= q[1 + i];
    bool plain_ascii = true;
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t c = q[1 + i];
      plain_ascii &= (c >= 0x20) & (c < 0x7F);
    }
    if (padding != 0) {
      fail(ErrorCode::kBadString, f, n, N, "non-zero padding");
    } else if (!plain_ascii && !is_wire_string(s.view())) {
      fail(ErrorCode::kBadString, f, n, N, "invalid UTF-8 or a control character");
    }
  }
  bool plane_count(std::uint8_t& count, const char* f) noexcept {
    count = take(1)[0];
    if (truncated_) return false;
    if (count < kMinPlanePoints || count > kMaxPlanePoints) {
      structural(ErrorCode::kBadCount, f, count);
      return false;
    }
    return true;
  }
  bool ack_type(MessageType& t, const char* f) noexcept {
    t = static_cast<MessageType>(get_u16(take(2)));
    if (truncated_) return false;
    if (!is_request(t) || minor_of(t) > minor_) {
      structural(ErrorCode::kInvalidEnumValue, f, static_cast<std::uint16_t>(t), 0, "acknowledged");
      return false;
    }
    return true;
  }
  template <typename T>
  T* body(AckBody& b) noexcept {
    return &b.template emplace<T>();
  }

  // The outcome, in the documented order of precedence.
  bool finish(bool allow_tail, DecodeError& e) const noexcept {
    if (structural_) {
      set(e);
    } else if (truncated_ || (!allow_tail && pos_ != size_)) {
      e.code = ErrorCode::kBadPayloadLength;
      e.field = "header.payload_length";
      e.value = size_;
      e.limit = needed_;
      e.reason = allow_tail ? "at least " : "";
    } else if (code_ != ErrorCode::kOk) {
      set(e);
    } else {
      return true;
    }
    return false;
  }

 private:
  const std::uint8_t* take(std::size_t n) noexcept {
    needed_ += n;
    if (size_ - pos_ < n) {
      truncated_ = true;
      pos_ = size_;
      return kZeros.data();
    }
    const std::uint8_t* q = p_ + pos_;
    pos_ += n;
    return q;
  }
  const std::uint8_t* take_block(std::size_t n) noexcept {
    needed_ += n;
    if (size_ - pos_ < n) {
      truncated_ = true;
      pos_ = size_;
      return nullptr;
    }
    const std::uint8_t* q = p_ + pos_;
    pos_ += n;
    return q;
  }
  // The first failing field wins (wire order). A truncated payload reads zeros, which never fail.
  void fail(ErrorCode c, const char* f, std::uint64_t value, std::uint64_t limit,
            const char* reason = "") noexcept {
    if (code_ == ErrorCode::kOk && !truncated_) {
      code_ = c;
      field_ = f;
      value_ = value;
      limit_ = limit;
      reason_ = reason;
    }
  }
  void structural(ErrorCode c, const char* f, std::uint64_t value, std::uint64_t limit = 0,
                  const char* reason = "") noexcept {
    code_ = ErrorCode::kOk;
    fail(c, f, value, limit, reason);
    structural_ = true;
  }
  void set(DecodeError& e) const noexcept {
    e.code = code_;
    e.field = field_;
    e.value = value_;
    e.limit = limit_;
    e.reason = reason_;
  }

  const std::uint8_t* p_;
  std::size_t size_;
  std::uint8_t minor_;
  std::size_t pos_ = 0;
  std::size_t needed_ = 0;  // bytes the layout needs (counted also past a truncation)
  std::uint64_t value_ = 0;
  std::uint64_t limit_ = 0;
  const char* reason_ = "";
  bool truncated_ = false;
  bool structural_ = false;
  ErrorCode code_ = ErrorCode::kOk;
  const char* field_ = "";
};

}  // namespace ajar::protocol::detail
