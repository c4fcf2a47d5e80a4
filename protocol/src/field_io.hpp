// The two ends of a payload: the Writer (message -> bytes) and the Reader (bytes -> message, with
// every check of docs/protocol.md section 3). walk.hpp drives both along the message tables, so
// they cannot disagree; a scalar's size, conversion and check come from its wire type
// (schema.hpp). This file says only how bytes are put, taken and refused.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
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

// Sixteen bytes as one GCC vector: SSE2 on x86-64, NEON on arm64, the same code on both (vector
// extensions, no intrinsics). A comparison gives 0xFF in every byte where it holds, else 0.
typedef std::uint8_t Bytes16 __attribute__((vector_size(16)));
typedef std::int8_t SignedBytes16 __attribute__((vector_size(16)));
inline constexpr Bytes16 kByteIndex = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
[[gnu::always_inline]] inline bool any_byte_set(Bytes16 v) noexcept {
  const auto halves = std::bit_cast<std::array<std::uint64_t, 2>>(v);
  return (halves[0] | halves[1]) != 0;
}

// A string field's N bytes p[0, N), of which the first n are the string (n <= 255, the wire's u8
// length; n >= N: all of them), copied to `copy` and scanned: are the bytes [n, N) all zero, and
// are the bytes [0, n) all printable ASCII (0x20..0x7E)? Sixteen bytes at a time, with no branch
// on the bytes and a trip count known at compile time (unrolled); a capacity that is not a
// multiple of sixteen ends with the last sixteen bytes, overlapping the chunk before (the scan
// never reads outside p[0, N)). Each chunk's bytes are split by their index against n: a byte
// past the string is ORed into `padding`, and every byte must be printable or past the string
// (ANDed into `plain_or_padding`). A byte b is printable ASCII exactly when b + 1, as a signed
// byte, is above 0x20: 0x20..0x7E give 0x21..0x7F, every other value -128..0x20. It replaced eight
// bytes at a time with masks in 64-bit words (docs/performance.md, "Stream decode vs CRC-only");
// tests/protocol/string_scan_test.cpp holds it to a byte-by-byte reading.
struct StringScan {
  bool padding_zero;
  bool plain_ascii;
};
template <std::size_t N>
[[gnu::always_inline]] inline StringScan copy_and_scan_string(const std::uint8_t* p, std::uint8_t n,
                                                              char* copy) noexcept {
  static_assert(N >= sizeof(Bytes16), "string capacities are at least sixteen bytes");
  static_assert(N <= 255, "a string's length is one byte (the lanes' index arithmetic too)");
  const Bytes16 length = Bytes16{} + n;
  Bytes16 padding{}, plain_or_padding = ~Bytes16{};
  for (std::size_t i = 0; i < (N + sizeof(Bytes16) - 1) / sizeof(Bytes16); ++i) {
    const std::size_t k = std::min(i * sizeof(Bytes16), N - sizeof(Bytes16));
    Bytes16 w;
    std::memcpy(&w, p + k, sizeof w);
    std::memcpy(copy + k, &w, sizeof w);
    const auto past_string =
        std::bit_cast<Bytes16>(kByteIndex + static_cast<std::uint8_t>(k) >= length);
    padding |= w & past_string;
    const auto printable = std::bit_cast<SignedBytes16>(w + 1) > 0x20;
    plain_or_padding &= std::bit_cast<Bytes16>(printable) | past_string;
  }
  return {!any_byte_set(padding), !any_byte_set(~plain_or_padding)};
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
    s.length = n;
    // Padding must be zero; printable ASCII needs no UTF-8 pass.
    const StringScan scan = copy_and_scan_string<N>(q + 1, n, s.bytes.data());
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
    s.length = std::min<std::uint8_t>(n, N);  // a refused frame's string still views in bounds
    const StringScan scan = copy_and_scan_string<N>(q + 1, n, s.bytes.data());
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
