// The two ends of a payload: the Writer (message -> bytes) and the Reader (bytes -> message, with
// every check of docs/protocol.md section 3). walk.hpp drives both along the message tables, so
// they cannot disagree; a scalar's size, conversion and check come from its wire type
// (schema.hpp). This file says only how bytes are put, taken and refused.
#pragma once

#include <algorithm>
#include <array>
#include <cstring>
#include <span>

#include "ajar/protocol/codec.hpp"
#include "little_endian.hpp"
#include "schema.hpp"

namespace ajar::protocol::detail {

// ---- Writer: message -> payload bytes ---------------------------------------------------------

class Writer {
 public:
  Writer(std::uint8_t* out, std::size_t capacity, std::uint8_t minor) noexcept
      : p_(out), cap_(capacity), minor_(minor) {}
  bool ok() const noexcept { return ok_; }
  std::uint8_t minor() const noexcept { return minor_; }
  // True when the layout being written has the fields that minor version `m` appended.
  bool since(std::uint8_t m) const noexcept { return minor_ >= m; }
  std::size_t size() const noexcept { return pos_; }

  template <typename W, typename V>
  [[gnu::always_inline]] void scalar(const V& v, const char*) noexcept {
    if (std::uint8_t* q = take(sizeof(typename W::raw))) store(q, W::to_raw(v));
  }
  template <std::size_t N>
  void str(const FixedString<N>& s, const char*) noexcept {
    std::uint8_t* q = take(1 + N);
    if (q == nullptr) return;
    const std::size_t n = std::min<std::size_t>(s.length, N);
    q[0] = static_cast<std::uint8_t>(n);
    std::memcpy(q + 1, s.bytes.data(), n);
    std::memset(q + 1 + n, 0, N - n);
  }
  template <std::size_t N>
  void bytes(const FixedBytes<N>& b, const char*) noexcept {
    std::uint8_t* q = take(2 + N);
    if (q == nullptr) return;
    const std::size_t n = std::min<std::size_t>(b.length, N);
    store(q, static_cast<std::uint16_t>(n));
    std::memcpy(q + 2, b.bytes.data(), n);
    std::memset(q + 2 + n, 0, N - n);
  }
  // A field that sizes the payload (count, acknowledged): the writer refuses what the reader would.
  bool sizes(bool valid, ErrorCode, const char*, std::uint64_t, const char*) noexcept {
    if (!valid) ok_ = false;
    return ok_;
  }
  template <typename T>
  const T* body(const AckBody& b) noexcept {
    const T* p = std::get_if<T>(&b);
    if (p == nullptr) ok_ = false;
    return p;
  }

 private:
  [[gnu::always_inline]] std::uint8_t* take(std::size_t n) noexcept {
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
  std::uint8_t minor() const noexcept { return minor_; }
  bool since(std::uint8_t m) const noexcept { return minor_ >= m; }

  template <typename W, typename V>
  [[gnu::always_inline]] void scalar(V& v, const char* f) noexcept {
    using Raw = typename W::raw;
    const Raw raw = load<Raw>(take(sizeof(Raw)));
    v = W::template from_raw<V>(raw);
    if (const Problem p = W::check(raw); p.code != ErrorCode::kOk) {
      fail(p.code, f, raw, p.limit, p.reason);
    }
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
  // bytes<N> (1.2): a u16 length L (0..N, else BAD_COUNT), then N bytes whose last N - L are zero
  // (else BAD_COUNT).
  template <std::size_t N>
  void bytes(FixedBytes<N>& b, const char* f) noexcept {
    const std::uint8_t* q = take_block(2 + N);
    if (q == nullptr) return;
    const std::uint16_t n = load<std::uint16_t>(q);
    if (n > N) {
      fail(ErrorCode::kBadCount, f, n, N, "length above capacity");
      return;
    }
    std::memcpy(b.bytes.data(), q + 2, N);
    b.length = n;
    std::uint8_t padding = 0;
    for (std::size_t i = n; i < N; ++i)
      padding |= q[2 + i];
    if (padding != 0) fail(ErrorCode::kBadCount, f, n, N, "non-zero padding");
  }
  // A field that sizes the payload: a wrong value is reported before the length check (it decides
  // the length) and stops the walk.
  bool sizes(bool valid, ErrorCode code, const char* f, std::uint64_t value,
             const char* reason) noexcept {
    if (truncated_) return false;
    if (!valid) {
      structural(code, f, value, reason);
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
  // The next n bytes; past the end (a truncated payload) zeros, which never fail a check.
  [[gnu::always_inline]] const std::uint8_t* take(std::size_t n) noexcept {
    const std::uint8_t* q = take_block(n);
    return q == nullptr ? kZeros.data() : q;
  }
  [[gnu::always_inline]] const std::uint8_t* take_block(std::size_t n) noexcept {
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
  // The first failing field wins (wire order).
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
  void structural(ErrorCode c, const char* f, std::uint64_t value, const char* reason) noexcept {
    code_ = ErrorCode::kOk;
    fail(c, f, value, 0, reason);
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
