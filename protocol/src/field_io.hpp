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

// The two scans of a string field's N bytes p[0, N) of which the first n are the string: are the
// bytes [n, N) all zero, and are the bytes [0, n) all printable ASCII (0x20..0x7E)? Eight bytes at
// a time, with no branch on the bytes and a trip count known at compile time (unrolled): each
// word's bytes are split by a mask of their index against n. A byte b is not printable ASCII when
// its top bit is set, or when x = b & 0x7F is below 0x20 (x + 0x60 has no top bit) or is 0x7F
// (x + 0x01 has it); no sum carries into the next byte (x + 0x60 <= 0xDF). It replaced two loops
// with run-time bounds (docs/performance.md, "Protocol").
struct StringScan {
  bool padding_zero;
  bool plain_ascii;
};
template <std::size_t N>
[[gnu::always_inline]] inline StringScan scan_string(const std::uint8_t* p,
                                                     std::size_t n) noexcept {
  static_assert(N % 8 == 0, "string capacities are whole words");
  constexpr std::uint64_t kLow7 = 0x7F7F7F7F7F7F7F7FULL, kTop = 0x8080808080808080ULL;
  constexpr std::uint64_t k60 = 0x6060606060606060ULL, k01 = 0x0101010101010101ULL;
  std::uint64_t padding = 0, not_plain = 0;
  for (std::size_t k = 0; k < N; k += 8) {
    const std::uint64_t w = get_u64(p + k);  // byte k + i in bits 8i..8i+7
    const std::size_t in = n > k ? std::min<std::size_t>(n - k, 8) : 0;  // string bytes here
    const std::uint64_t string_bytes = in == 0 ? 0 : ~0ULL >> (64 - 8 * in);
    padding |= w & ~string_bytes;
    const std::uint64_t x = w & kLow7;
    not_plain |= (w | ~(x + k60) | (x + k01)) & kTop & string_bytes;
  }
  return {padding == 0, not_plain == 0};
}

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
    // Padding must be zero; printable ASCII needs no UTF-8 pass.
    const StringScan scan = scan_string<N>(q + 1, n);
    if (!scan.padding_zero) {
      fail(ErrorCode::kBadString, f, n, N, "non-zero padding");
    } else if (!scan.plain_ascii && !is_wire_string(s.view())) {
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

// ---- FastReader: a payload of the layout's exact length, in one pass ---------------------------
// The decoder's fast path (codec.cpp): the payload's length has been found equal to the layout's
// (payload_size(), walk.hpp), so no field needs a bounds check, and a failed check only has to be
// noticed, not described: the fields are read at offsets the compiler knows, every check's verdict
// goes into one flag, and when it is set the checked Reader walks the payload again and reports
// the first failure exactly as it always has. ok() is true only where the Reader would decode
// the same values without an error.
class FastReader {
 public:
  FastReader(const std::uint8_t* payload, std::uint8_t minor) noexcept
      : p_(payload), minor_(minor) {}
  std::uint8_t minor() const noexcept { return minor_; }
  bool since(std::uint8_t m) const noexcept { return minor_ >= m; }
  bool ok() const noexcept { return !bad_; }

  template <typename W, typename V>
  [[gnu::always_inline]] void scalar(V& v, const char*) noexcept {
    using Raw = typename W::raw;
    const Raw raw = load<Raw>(take(sizeof(Raw)));
    v = W::template from_raw<V>(raw);
    if (W::check(raw).code != ErrorCode::kOk) [[unlikely]] {
      bad_ = true;
    }
  }
  template <std::size_t N>
  [[gnu::always_inline]] void str(FixedString<N>& s, const char*) noexcept {
    const std::uint8_t* q = take(1 + N);
    const std::uint8_t n = q[0];
    std::memcpy(s.bytes.data(), q + 1, N);
    s.length = n;
    const StringScan scan = scan_string<N>(q + 1, n);
    bad_ |= n > N || !scan.padding_zero;
    if (!bad_ && !scan.plain_ascii) bad_ = !is_wire_string(s.view());
  }
  template <std::size_t N>
  [[gnu::always_inline]] void bytes(FixedBytes<N>& b, const char*) noexcept {
    const std::uint8_t* q = take(2 + N);
    const std::uint16_t n = load<std::uint16_t>(q);
    std::memcpy(b.bytes.data(), q + 2, N);
    b.length = n;
    std::uint8_t padding = 0;
    for (std::size_t i = n; i < N; ++i)
      padding |= q[2 + i];
    bad_ |= n > N || padding != 0;
  }
  bool sizes(bool valid, ErrorCode, const char*, std::uint64_t, const char*) noexcept {
    bad_ |= !valid;
    return valid;
  }
  template <typename T>
  T* body(AckBody& b) noexcept {
    return &b.template emplace<T>();
  }

 private:
  [[gnu::always_inline]] const std::uint8_t* take(std::size_t n) noexcept {
    const std::uint8_t* q = p_ + pos_;
    pos_ += n;
    return q;
  }
  const std::uint8_t* p_;
  std::size_t pos_ = 0;
  std::uint8_t minor_;
  bool bad_ = false;
};

}  // namespace ajar::protocol::detail
