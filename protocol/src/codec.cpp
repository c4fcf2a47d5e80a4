// Frame and payload codec. One description per message (the *_fields functions below) drives both
// the Writer (encode) and the Reader (decode + validation), so the two cannot disagree.
#include "ajar/protocol/codec.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string_view>
#include <type_traits>

#include "ajar/protocol/crc32c.hpp"

namespace ajar::protocol {

namespace {

// ---- little-endian helpers --------------------------------------------------------------------

inline void put_u16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
inline void put_u32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i)
    p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void put_u64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i)
    p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline std::uint16_t get_u16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
// Written as one expression of shifted bytes: compilers turn it into a single load.
inline std::uint32_t get_u32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
inline std::uint64_t get_u64(const std::uint8_t* p) noexcept {
  return static_cast<std::uint64_t>(get_u32(p)) |
         (static_cast<std::uint64_t>(get_u32(p + 4)) << 32);
}

constexpr std::size_t kOffMagic = 0, kOffMajor = 4, kOffMinor = 5, kOffType = 6, kOffFlags = 8,
                      kOffRequestId = 10, kOffLength = 14, kOffCrc = 18;
static_assert(kOffCrc + 4 == kHeaderSize);
constexpr std::array<std::uint8_t, 4> kMagicBytes = {0x41, 0x4A, 0x41, 0x52};  // "AJAR"

// Enum table sizes (values 0..count-1 are valid).
constexpr std::uint8_t kFrameCount = 2, kDirectionCount = 2, kRoleCount = 2, kStateCount = 10,
                       kEventKindCount = 7, kArmStateCount = 5, kDriverStateCount = 4,
                       kDriverKindCount = 3, kPolicyCount = 3;

// ---- field names (static storage: DecodeError::field is a const char*) ------------------------

struct VecNames {
  const char* x;
  const char* y;
  const char* z;
};
struct PointNames {
  const char* frame;
  VecNames position;
};

struct PlanePointNameTable {
  std::array<std::array<std::array<char, 20>, 4>, kMaxPlanePoints> names{};
};
constexpr PlanePointNameTable make_plane_point_names() {
  PlanePointNameTable t;
  constexpr const char* kSuffix[4] = {".frame", ".x", ".y", ".z"};
  for (std::size_t i = 0; i < kMaxPlanePoints; ++i) {
    for (std::size_t k = 0; k < 4; ++k) {
      auto& s = t.names[i][k];
      std::size_t n = 0;
      for (const char* c = "points["; *c != '\0'; ++c)
        s[n++] = *c;
      if (i >= 10) s[n++] = static_cast<char>('0' + i / 10);
      s[n++] = static_cast<char>('0' + i % 10);
      s[n++] = ']';
      for (const char* c = kSuffix[k]; *c != '\0'; ++c)
        s[n++] = *c;
      s[n] = '\0';
    }
  }
  return t;
}
constexpr PlanePointNameTable kPlanePointNames = make_plane_point_names();
PointNames plane_point_names(std::size_t i) noexcept {
  const auto& n = kPlanePointNames.names[i];
  return {n[0].data(), {n[1].data(), n[2].data(), n[3].data()}};
}

struct SpanNames {
  const char* length_m;
  const char* direction;
  VecNames p1;
  VecNames p2;
};
struct PlaneNames {
  VecNames normal;
  const char* yaw_deviation_rad;
  const char* left_wheel_rad;
  const char* right_wheel_rad;
  const char* left_counts;
  const char* right_counts;
  const char* residual_yaw_rad;
  const char* rms_residual_m;
  const char* point_count;
};
struct ContactNames {
  VecNames contact;
  const char* reach_margin_m;
};

constexpr SpanNames kAckSpan{"length_m",
                             "direction",
                             {"p1_base_m.x", "p1_base_m.y", "p1_base_m.z"},
                             {"p2_base_m.x", "p2_base_m.y", "p2_base_m.z"}};
constexpr SpanNames kStatusWidth{"width.length_m",
                                 "width.direction",
                                 {"width.p1_base_m.x", "width.p1_base_m.y", "width.p1_base_m.z"},
                                 {"width.p2_base_m.x", "width.p2_base_m.y", "width.p2_base_m.z"}};
constexpr SpanNames kStatusHandle{
    "handle.length_m",
    "handle.direction",
    {"handle.p1_base_m.x", "handle.p1_base_m.y", "handle.p1_base_m.z"},
    {"handle.p2_base_m.x", "handle.p2_base_m.y", "handle.p2_base_m.z"}};
constexpr PlaneNames kAckPlane{{"normal.x", "normal.y", "normal.z"},
                               "yaw_deviation_rad",
                               "left_wheel_rad",
                               "right_wheel_rad",
                               "left_counts",
                               "right_counts",
                               "residual_yaw_rad",
                               "rms_residual_m",
                               "point_count"};
constexpr PlaneNames kStatusPlane{{"plane.normal.x", "plane.normal.y", "plane.normal.z"},
                                  "plane.yaw_deviation_rad",
                                  "plane.left_wheel_rad",
                                  "plane.right_wheel_rad",
                                  "plane.left_counts",
                                  "plane.right_counts",
                                  "plane.residual_yaw_rad",
                                  "plane.rms_residual_m",
                                  "plane.point_count"};
constexpr ContactNames kAckContact{{"contact_base_m.x", "contact_base_m.y", "contact_base_m.z"},
                                   "reach_margin_m"};
constexpr ContactNames kStatusContact{
    {"contact.contact_base_m.x", "contact.contact_base_m.y", "contact.contact_base_m.z"},
    "contact.reach_margin_m"};

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
  void vec3(const core::Vec3& v, const VecNames& n) noexcept {
    f64(v.x(), n.x);
    f64(v.y(), n.y);
    f64(v.z(), n.z);
  }
  void point(const core::FramedPoint& p, const PointNames& n) noexcept {
    enumeration(p.frame, n.frame, kFrameCount);
    vec3(p.position_m, n.position);
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
  void vec3(core::Vec3& v, const VecNames& n) noexcept {
    f64(v.x(), n.x);
    f64(v.y(), n.y);
    f64(v.z(), n.z);
  }
  void point(core::FramedPoint& p, const PointNames& n) noexcept {
    enumeration(p.frame, n.frame, kFrameCount);
    vec3(p.position_m, n.position);
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

// ---- the payload layouts (docs/protocol.md has the same tables) -------------------------------
// M is `const T` when encoding and `T` when decoding.

template <typename IO, typename M>
void span_fields(IO& io, M& m, const SpanNames& n) {
  io.f64(m.length_m, n.length_m);
  io.enumeration(m.direction, n.direction, kDirectionCount);
  io.vec3(m.p1_base_m, n.p1);
  io.vec3(m.p2_base_m, n.p2);
}

template <typename IO, typename M>
void plane_fields(IO& io, M& m, const PlaneNames& n) {
  io.vec3(m.normal, n.normal);
  io.f64(m.yaw_deviation_rad, n.yaw_deviation_rad);
  io.f64(m.left_wheel_rad, n.left_wheel_rad);
  io.f64(m.right_wheel_rad, n.right_wheel_rad);
  io.i64(m.left_counts, n.left_counts);
  io.i64(m.right_counts, n.right_counts);
  io.f64(m.residual_yaw_rad, n.residual_yaw_rad);
  io.f64(m.rms_residual_m, n.rms_residual_m);
  io.u8(m.point_count, n.point_count);
}

template <typename IO, typename M>
void contact_fields(IO& io, M& m, const ContactNames& n) {
  io.vec3(m.contact_base_m, n.contact);
  io.f64(m.reach_margin_m, n.reach_margin_m);
}

template <typename IO, typename M>
void loop_fields(IO& io, M& m) {
  io.f32(m.rate_hz, "loop.rate_hz");
  io.u64(m.cycles, "loop.cycles");
  io.u64(m.overruns, "loop.overruns");
  io.u32(m.period_p50_ns, "loop.period_p50_ns");
  io.u32(m.period_p99_ns, "loop.period_p99_ns");
  io.u32(m.period_max_ns, "loop.period_max_ns");
  io.u32(m.jitter_p99_ns, "loop.jitter_p99_ns");
}

template <typename IO, typename M>
void quantile_fields(IO& io, M& m, const std::array<const char*, 4>& n) {
  io.u32(m.p50_ns, n[0]);
  io.u32(m.p99_ns, n[1]);
  io.u32(m.p999_ns, n[2]);
  io.u32(m.max_ns, n[3]);
}

#define AJAR_QUANTILE_NAMES(prefix) \
  { prefix ".p50_ns", prefix ".p99_ns", prefix ".p999_ns", prefix ".max_ns" }

template <typename IO, typename M>
void timing_fields(IO& io, M& m) {
  io.f32(m.window_s, "timing.window_s");
  io.u64(m.all.samples, "timing.all.samples");
  quantile_fields(io, m.all.latency, AJAR_QUANTILE_NAMES("timing.all.latency"));
  quantile_fields(io, m.all.execution, AJAR_QUANTILE_NAMES("timing.all.execution"));
  quantile_fields(io, m.all.period, AJAR_QUANTILE_NAMES("timing.all.period"));
  io.u64(m.recent.samples, "timing.recent.samples");
  quantile_fields(io, m.recent.latency, AJAR_QUANTILE_NAMES("timing.recent.latency"));
  quantile_fields(io, m.recent.execution, AJAR_QUANTILE_NAMES("timing.recent.execution"));
  quantile_fields(io, m.recent.period, AJAR_QUANTILE_NAMES("timing.recent.period"));
}
#undef AJAR_QUANTILE_NAMES

// The 1.1 block appended to Status and Telemetry (same layout in both).
template <typename IO, typename M>
void motion_fields(IO& io, M& m) {
  io.f64(m.odometry_x_m, "odometry_x_m");
  io.f64(m.odometry_y_m, "odometry_y_m");
  io.boolean(m.door.has_distance, "door.has_distance");
  io.f64(m.door.distance_m, "door.distance_m");
  io.boolean(m.door.has_yaw, "door.has_yaw");
  io.f64(m.door.yaw_rad, "door.yaw_rad");
  io.boolean(m.staleness.plane, "staleness.plane");
  io.boolean(m.staleness.contact, "staleness.contact");
  io.f64(m.staleness.travel_since_plane_m, "staleness.travel_since_plane_m");
  io.f64(m.commanded_linear_m_s, "commanded_linear_m_s");
  io.f64(m.commanded_angular_rad_s, "commanded_angular_rad_s");
  timing_fields(io, m.timing);
}

constexpr std::array<const char*, 12> kTransformNames = {
    "camera_to_base[0]", "camera_to_base[1]", "camera_to_base[2]",  "camera_to_base[3]",
    "camera_to_base[4]", "camera_to_base[5]", "camera_to_base[6]",  "camera_to_base[7]",
    "camera_to_base[8]", "camera_to_base[9]", "camera_to_base[10]", "camera_to_base[11]"};

template <typename IO, typename M>
void robot_model_fields(IO& io, M& m) {
  for (std::size_t i = 0; i < m.camera_to_base.size(); ++i)
    io.f64(m.camera_to_base[i], kTransformNames[i]);
  io.f64(m.wheel_radius_m, "wheel_radius_m");
  io.f64(m.turning_radius_m, "turning_radius_m");
  io.f64(m.encoder_counts_per_rev, "encoder_counts_per_rev");
  io.f64(m.gear_ratio, "gear_ratio");
  io.u8(m.left.card_axis, "left.card_axis");
  io.polarity(m.left.polarity, "left.polarity");
  io.u8(m.right.card_axis, "right.card_axis");
  io.polarity(m.right.polarity, "right.polarity");
  io.f64(m.max_wheel_speed_rad_s, "max_wheel_speed_rad_s");
  io.f64(m.max_wheel_accel_rad_s2, "max_wheel_accel_rad_s2");
  io.f64(m.max_linear_speed_m_s, "max_linear_speed_m_s");
  io.f64(m.max_angular_speed_rad_s, "max_angular_speed_rad_s");
  io.f64(m.max_linear_accel_m_s2, "max_linear_accel_m_s2");
  io.f64(m.max_angular_accel_rad_s2, "max_angular_accel_rad_s2");
  io.f64(m.drive_command_timeout_s, "drive_command_timeout_s");
  io.f64(m.approach_max_travel_m, "approach_max_travel_m");
  io.f64(m.approach_square_tolerance_rad, "approach_square_tolerance_rad");
  io.f64(m.approach_min_standoff_m, "approach_min_standoff_m");
  io.f64(m.stale_travel_m, "stale_travel_m");
  io.f64(m.stale_yaw_rad, "stale_yaw_rad");
  io.vec3(m.arm_shoulder_m, VecNames{"arm_shoulder_m.x", "arm_shoulder_m.y", "arm_shoulder_m.z"});
  io.f64(m.arm_min_reach_m, "arm_min_reach_m");
  io.f64(m.arm_max_reach_m, "arm_max_reach_m");
  io.f64(m.arm_min_z_m, "arm_min_z_m");
  io.f64(m.arm_max_z_m, "arm_max_z_m");
  io.f64(m.min_depth_m, "min_depth_m");
  io.f64(m.max_depth_m, "max_depth_m");
  io.f64(m.min_door_width_m, "min_door_width_m");
  io.f64(m.max_door_width_m, "max_door_width_m");
  io.f64(m.min_handle_length_m, "min_handle_length_m");
  io.f64(m.max_handle_length_m, "max_handle_length_m");
  io.f64(m.max_yaw_correction_rad, "max_yaw_correction_rad");
  io.f64(m.aligned_tolerance_rad, "aligned_tolerance_rad");
  io.f64(m.min_point_separation_m, "min_point_separation_m");
  io.f64(m.min_lateral_fraction, "min_lateral_fraction");
  io.f64(m.collinearity, "collinearity");
  io.f64(m.max_plane_rms_m, "max_plane_rms_m");
  io.f64(m.max_door_tilt_rad, "max_door_tilt_rad");
}

template <typename IO, typename M>
void approach_ack_fields(IO& io, M& m) {
  io.f64(m.travel_m, "travel_m");
  io.f64(m.start_distance_m, "start_distance_m");
  io.i64(m.left_counts, "left_counts");
  io.i64(m.right_counts, "right_counts");
}

constexpr PointNames kP1{"p1.frame", {"p1.x", "p1.y", "p1.z"}};
constexpr PointNames kP2{"p2.frame", {"p2.x", "p2.y", "p2.z"}};
constexpr PointNames kContactPoint{"contact.frame", {"contact.x", "contact.y", "contact.z"}};

enum class AckKind { kEmpty, kSpan, kPlane, kContact, kApproach };
AckKind ack_kind(MessageType acknowledged) noexcept {
  switch (acknowledged) {
    case MessageType::kMeasureDoorWidth:
    case MessageType::kMeasureHandle:
      return AckKind::kSpan;
    case MessageType::kMeasureDoorPlane:
      return AckKind::kPlane;
    case MessageType::kSetContactPoint:
      return AckKind::kContact;
    case MessageType::kApproach:
      return AckKind::kApproach;
    default:
      return AckKind::kEmpty;
  }
}

template <typename IO, typename M>
void fields(IO& io, M& m) {
  using T = std::remove_const_t<M>;
  if constexpr (std::is_same_v<T, Hello>) {
    io.u8(m.version_major, "version_major");
    io.u8(m.version_minor, "version_minor");
    io.enumeration(m.requested_role, "requested_role", kRoleCount);
    io.boolean(m.take_over, "take_over");
    io.u64(m.client_instance_id, "client_instance_id");
    io.str(m.client_name, "client_name");
  } else if constexpr (std::is_same_v<T, Ping>) {
    io.u64(m.client_time_ns, "client_time_ns");
  } else if constexpr (std::is_same_v<T, MeasureDoorWidth>) {
    io.point(m.p1_hinge, kP1);
    io.point(m.p2_moving_edge, kP2);
  } else if constexpr (std::is_same_v<T, MeasureHandle>) {
    io.point(m.p1_axis, kP1);
    io.point(m.p2_free_end, kP2);
  } else if constexpr (std::is_same_v<T, MeasureDoorPlane>) {
    if (!io.plane_count(m.count, "count")) return;
    for (std::size_t i = 0; i < m.count; ++i)
      io.point(m.points[i], plane_point_names(i));
  } else if constexpr (std::is_same_v<T, SetContactPoint>) {
    io.point(m.contact, kContactPoint);
  } else if constexpr (std::is_same_v<T, Reset>) {
    io.boolean(m.clear_parameters, "clear_parameters");
  } else if constexpr (std::is_same_v<T, Subscribe>) {
    io.f32(m.telemetry_rate_hz, "telemetry_rate_hz");
  } else if constexpr (std::is_same_v<T, Welcome>) {
    io.u8(m.version_major, "version_major");
    io.u8(m.version_minor, "version_minor");
    io.enumeration(m.granted_role, "granted_role", kRoleCount);
    io.u64(m.session_id, "session_id");
    io.str(m.daemon_version, "daemon_version");
    io.f32(m.loop_rate_hz, "loop_rate_hz");
    io.f32(m.deadman_timeout_s, "deadman_timeout_s");
    io.f32(m.min_door_width_m, "min_door_width_m");
    io.f32(m.max_door_width_m, "max_door_width_m");
    io.f32(m.min_handle_length_m, "min_handle_length_m");
    io.f32(m.max_handle_length_m, "max_handle_length_m");
    io.f32(m.max_yaw_correction_rad, "max_yaw_correction_rad");
    if (!io.since(1)) return;
    io.enumeration(m.driver_kind, "driver_kind", kDriverKindCount);
  } else if constexpr (std::is_same_v<T, Pong>) {
    io.u64(m.client_time_ns, "client_time_ns");
    io.u64(m.daemon_time_ns, "daemon_time_ns");
  } else if constexpr (std::is_same_v<T, Ack>) {
    if (!io.ack_type(m.acknowledged, "acknowledged")) return;
    io.enumeration(m.state, "state", kStateCount);
    switch (ack_kind(m.acknowledged)) {
      case AckKind::kSpan:
        if (auto* b = io.template body<SpanAck>(m.body)) span_fields(io, *b, kAckSpan);
        break;
      case AckKind::kPlane:
        if (auto* b = io.template body<PlaneAck>(m.body)) plane_fields(io, *b, kAckPlane);
        break;
      case AckKind::kContact:
        if (auto* b = io.template body<ContactAck>(m.body)) contact_fields(io, *b, kAckContact);
        break;
      case AckKind::kApproach:
        if (auto* b = io.template body<ApproachAck>(m.body)) approach_ack_fields(io, *b);
        break;
      case AckKind::kEmpty:
        io.template body<EmptyAck>(m.body);
        break;
    }
  } else if constexpr (std::is_same_v<T, ErrorReply>) {
    io.error_code(m.code, "code");
    io.raw_type(m.offending_type, "offending_type");
    io.str(m.field, "field");
    io.str(m.message, "message");
  } else if constexpr (std::is_same_v<T, Event>) {
    io.enumeration(m.kind, "kind", kEventKindCount);
    io.enumeration(m.state, "state", kStateCount);
    io.error_code(m.fault, "fault");
    io.u64(m.daemon_time_ns, "daemon_time_ns");
    io.str(m.detail, "detail");
  } else if constexpr (std::is_same_v<T, Status>) {
    io.enumeration(m.state, "state", kStateCount);
    io.error_code(m.latched_fault, "latched_fault");
    io.boolean(m.restored_from_disk, "restored_from_disk");
    io.boolean(m.controller_connected, "controller_connected");
    io.u16(m.session_count, "session_count");
    io.boolean(m.has_width, "has_width");
    span_fields(io, m.width, kStatusWidth);
    io.boolean(m.has_handle, "has_handle");
    span_fields(io, m.handle, kStatusHandle);
    io.boolean(m.has_plane, "has_plane");
    plane_fields(io, m.plane, kStatusPlane);
    io.boolean(m.has_contact, "has_contact");
    contact_fields(io, m.contact, kStatusContact);
    io.f64(m.base_yaw_odometry_rad, "base_yaw_odometry_rad");
    io.enumeration(m.card, "card", kDriverStateCount);
    io.enumeration(m.arm, "arm", kDriverStateCount);
    io.enumeration(m.arm_state, "arm_state", kArmStateCount);
    loop_fields(io, m.loop);
    if (!io.since(1)) return;
    motion_fields(io, m);
    io.enumeration(m.realtime.policy, "realtime.policy", kPolicyCount);
    io.u8(m.realtime.priority, "realtime.priority");
    io.boolean(m.realtime.memory_locked, "realtime.memory_locked");
  } else if constexpr (std::is_same_v<T, Telemetry>) {
    io.u64(m.daemon_time_ns, "daemon_time_ns");
    io.enumeration(m.state, "state", kStateCount);
    io.boolean(m.moving, "moving");
    io.f64(m.left_wheel_rad, "left_wheel_rad");
    io.f64(m.right_wheel_rad, "right_wheel_rad");
    io.i64(m.left_counts, "left_counts");
    io.i64(m.right_counts, "right_counts");
    io.f64(m.base_yaw_odometry_rad, "base_yaw_odometry_rad");
    io.enumeration(m.arm_state, "arm_state", kArmStateCount);
    loop_fields(io, m.loop);
    if (!io.since(1)) return;
    motion_fields(io, m);
  } else if constexpr (std::is_same_v<T, Drive>) {
    io.f64(m.linear_m_s, "linear_m_s");
    io.f64(m.angular_rad_s, "angular_rad_s");
  } else if constexpr (std::is_same_v<T, Approach>) {
    io.f64(m.standoff_m, "standoff_m");
  } else if constexpr (std::is_same_v<T, RobotModel>) {
    robot_model_fields(io, m);
  } else {
    // AlignBase, Engage, Stop, EmergencyStop, GetStatus, GetRobotModel, ResetLoopStatistics: empty.
    static_assert(std::is_empty_v<T>);
  }
}

template <typename T>
void decode_as(Reader& r, Message& m) noexcept {
  // Reuse the alternative when it is already there (a stream of Telemetry, say): every field is
  // overwritten. MeasureDoorPlane starts fresh so that points beyond `count` are default, and so
  // does an older layout (the fields it lacks keep their defaults).
  if constexpr (!std::is_same_v<T, MeasureDoorPlane>) {
    T* existing = std::get_if<T>(&m);
    if (existing != nullptr && r.since(kVersionMinor)) {
      fields(r, *existing);
      return;
    }
  }
  fields(r, m.template emplace<T>());
}

// Decodes the payload of a known type; false for an unknown type.
bool decode_payload(std::uint16_t type, Reader& r, Message& m) noexcept {
  switch (static_cast<MessageType>(type)) {
    case MessageType::kHello:
      decode_as<Hello>(r, m);
      return true;
    case MessageType::kPing:
      decode_as<Ping>(r, m);
      return true;
    case MessageType::kMeasureDoorWidth:
      decode_as<MeasureDoorWidth>(r, m);
      return true;
    case MessageType::kMeasureHandle:
      decode_as<MeasureHandle>(r, m);
      return true;
    case MessageType::kMeasureDoorPlane:
      decode_as<MeasureDoorPlane>(r, m);
      return true;
    case MessageType::kSetContactPoint:
      decode_as<SetContactPoint>(r, m);
      return true;
    case MessageType::kAlignBase:
      decode_as<AlignBase>(r, m);
      return true;
    case MessageType::kEngage:
      decode_as<Engage>(r, m);
      return true;
    case MessageType::kStop:
      decode_as<Stop>(r, m);
      return true;
    case MessageType::kEmergencyStop:
      decode_as<EmergencyStop>(r, m);
      return true;
    case MessageType::kReset:
      decode_as<Reset>(r, m);
      return true;
    case MessageType::kGetStatus:
      decode_as<GetStatus>(r, m);
      return true;
    case MessageType::kSubscribe:
      decode_as<Subscribe>(r, m);
      return true;
    case MessageType::kWelcome:
      decode_as<Welcome>(r, m);
      return true;
    case MessageType::kPong:
      decode_as<Pong>(r, m);
      return true;
    case MessageType::kAck:
      decode_as<Ack>(r, m);
      return true;
    case MessageType::kError:
      decode_as<ErrorReply>(r, m);
      return true;
    case MessageType::kEvent:
      decode_as<Event>(r, m);
      return true;
    case MessageType::kStatus:
      decode_as<Status>(r, m);
      return true;
    case MessageType::kTelemetry:
      decode_as<Telemetry>(r, m);
      return true;
    case MessageType::kDrive:
      decode_as<Drive>(r, m);
      return true;
    case MessageType::kApproach:
      decode_as<Approach>(r, m);
      return true;
    case MessageType::kGetRobotModel:
      decode_as<GetRobotModel>(r, m);
      return true;
    case MessageType::kResetLoopStatistics:
      decode_as<ResetLoopStatistics>(r, m);
      return true;
    case MessageType::kRobotModel:
      decode_as<RobotModel>(r, m);
      return true;
  }
  return false;
}

// Encodes the payload of `m` into `out`; returns its size, or nullopt-like 0 with ok=false.
bool encode_payload(const Message& m, std::span<std::uint8_t> out, std::size_t& size,
                    std::uint8_t minor = kVersionMinor) noexcept {
  Writer w(out.data(), std::min(out.size(), kMaxPayloadSize), minor);
  std::visit([&w](const auto& v) { fields(w, v); }, m);
  size = w.size();
  return w.ok();
}

// Checks of the first header bytes that decide whether the stream can continue.
bool check_header(const std::uint8_t* h, DecodeError& e) noexcept {
  e = DecodeError{};
  if (std::memcmp(h + kOffMagic, kMagicBytes.data(), kMagicBytes.size()) != 0) {
    e.code = ErrorCode::kBadMagic;
    e.framing_lost = true;
    e.field = "header.magic";
    return false;
  }
  e.type = get_u16(h + kOffType);
  e.request_id = get_u32(h + kOffRequestId);
  e.version_minor = h[kOffMinor];
  if (h[kOffMajor] != kVersionMajor) {
    e.code = ErrorCode::kUnsupportedVersion;
    e.framing_lost = true;
    e.field = "header.version_major";
    e.value = h[kOffMajor];
    return false;
  }
  const std::uint32_t length = get_u32(h + kOffLength);
  if (length > kMaxPayloadSize) {
    e.code = ErrorCode::kPayloadTooLarge;
    e.framing_lost = true;
    e.field = "header.payload_length";
    e.value = length;
    e.limit = kMaxPayloadSize;
    return false;
  }
  return true;
}

std::uint32_t frame_crc(const std::uint8_t* header,
                        std::span<const std::uint8_t> payload) noexcept {
  const std::uint32_t crc = crc32c_update(kCrc32cInit, header, kOffCrc);
  return crc32c_finish(crc32c_update(crc, payload.data(), payload.size()));
}

// Decodes one whole frame into `out` (reusing its storage). `header_checked`: check_header()
// already passed on these bytes and filled out.error.
void decode_into(std::span<const std::uint8_t> frame, StreamDecoder::Outcome& out,
                 bool header_checked = false) noexcept {
  DecodeError& e = out.error;
  out.kind = StreamDecoder::Kind::kError;
  if (frame.size() < kHeaderSize) {
    e = DecodeError{};
    e.code = ErrorCode::kBadPayloadLength;
    e.framing_lost = true;
    e.field = "frame";
    return;
  }
  const std::uint8_t* h = frame.data();
  if (!header_checked && !check_header(h, e)) return;
  const std::uint32_t length = get_u32(h + kOffLength);
  if (frame.size() != kHeaderSize + length) {
    e.code = ErrorCode::kBadPayloadLength;
    e.framing_lost = true;
    e.field = "frame";
    return;
  }
  const auto payload = frame.subspan(kHeaderSize);
#ifndef AJAR_PROTOCOL_FUZZING
  const std::uint32_t crc = frame_crc(h, payload);
  if (crc != get_u32(h + kOffCrc)) {
    e.code = ErrorCode::kCrcMismatch;
    e.field = "header.crc";
    e.value = get_u32(h + kOffCrc);
    e.limit = crc;
    return;
  }
#endif
  const std::uint16_t flags = get_u16(h + kOffFlags);
  if ((flags & ~static_cast<std::uint16_t>(kFlagKnownMask)) != 0) {
    e.code = ErrorCode::kUnknownFlags;
    e.field = "header.flags";
    e.value = flags;
    e.limit = kFlagKnownMask;
    return;
  }
  // The layout is the frame's minor version's (a newer minor: ours, extra bytes ignored).
  const std::uint8_t minor = std::min(h[kOffMinor], kVersionMinor);
  Reader r(payload, minor);
  if (minor_of(static_cast<MessageType>(e.type)) > minor ||
      !decode_payload(e.type, r, out.envelope.message)) {
    e.code = ErrorCode::kUnknownMessageType;
    e.field = "header.type";
    e.value = e.type;
    return;
  }
  if (!r.finish(h[kOffMinor] > kVersionMinor, e)) return;
  out.kind = StreamDecoder::Kind::kMessage;
  out.envelope.request_id = e.request_id;
  out.envelope.flags = flags;
  e = DecodeError{};
}

}  // namespace

std::size_t encode(const Envelope& envelope, std::span<std::uint8_t> out,
                   std::uint8_t minor) noexcept {
  if (out.size() < kHeaderSize || minor > kVersionMinor) return 0;
  if (minor_of(type_of(envelope.message)) > minor) return 0;
  std::size_t length = 0;
  if (!encode_payload(envelope.message, out.subspan(kHeaderSize), length, minor)) return 0;
  std::uint8_t* h = out.data();
  std::memcpy(h + kOffMagic, kMagicBytes.data(), kMagicBytes.size());
  h[kOffMajor] = kVersionMajor;
  h[kOffMinor] = minor;
  put_u16(h + kOffType, static_cast<std::uint16_t>(type_of(envelope.message)));
  put_u16(h + kOffFlags, envelope.flags);
  put_u32(h + kOffRequestId, envelope.request_id);
  put_u32(h + kOffLength, static_cast<std::uint32_t>(length));
  put_u32(h + kOffCrc, frame_crc(h, out.subspan(kHeaderSize, length)));
  return kHeaderSize + length;
}

bool encode_append(const Envelope& envelope, std::vector<std::uint8_t>& out, std::uint8_t minor) {
  const std::size_t old = out.size();
  out.resize(old + kMaxFrameSize);
  const std::size_t n = encode(envelope, std::span(out).subspan(old), minor);
  out.resize(old + n);
  return n != 0;
}

bool wire_equal(const Message& a, const Message& b) noexcept {
  if (a.index() != b.index()) return false;
  std::array<std::uint8_t, kMaxPayloadSize> ba{}, bb{};
  std::size_t na = 0, nb = 0;
  const bool oka = encode_payload(a, ba, na);
  const bool okb = encode_payload(b, bb, nb);
  return oka && okb && na == nb && std::memcmp(ba.data(), bb.data(), na) == 0;
}

std::string describe(const DecodeError& e) {
  std::string field = e.field == nullptr ? "" : e.field;
  const auto type_name = [&e] {
    const auto t = static_cast<MessageType>(e.type);
    char buffer[64];
    if (minor_of(t) == 255) {
      std::snprintf(buffer, sizeof buffer, "type 0x%04X", e.type);
    } else {
      std::snprintf(buffer, sizeof buffer, "%.*s", static_cast<int>(to_string(t).size()),
                    to_string(t).data());
    }
    return std::string(buffer);
  };
  char text[256];
  const auto v = static_cast<unsigned long long>(e.value);
  const auto l = static_cast<unsigned long long>(e.limit);
  switch (e.code) {
    case ErrorCode::kBadMagic:
      std::snprintf(text, sizeof text,
                    "header.magic: the frame does not start with \"AJAR\" (41 4A 41 52): "
                    "framing lost, closing the connection");
      break;
    case ErrorCode::kUnsupportedVersion:
      std::snprintf(text, sizeof text,
                    "header.version_major is %llu: this peer speaks protocol %u.x only: closing "
                    "the connection",
                    v, static_cast<unsigned>(kVersionMajor));
      break;
    case ErrorCode::kPayloadTooLarge:
      std::snprintf(text, sizeof text,
                    "header.payload_length is %llu: the maximum is %llu: framing lost, closing "
                    "the connection",
                    v, l);
      break;
    case ErrorCode::kCrcMismatch:
      std::snprintf(text, sizeof text,
                    "header.crc is 0x%08llX but header and payload give 0x%08llX: frame "
                    "corrupted, not executed; send it again",
                    v, l);
      break;
    case ErrorCode::kUnknownFlags:
      std::snprintf(text, sizeof text,
                    "header.flags is 0x%04llX: reserved bits set (this version knows 0x%04llX): "
                    "not executed",
                    v, l);
      break;
    case ErrorCode::kUnknownMessageType:
      if (minor_of(static_cast<MessageType>(e.type)) != 255) {
        std::snprintf(text, sizeof text,
                      "header.type 0x%04llX (%s) is defined from protocol %u.%u; the frame says "
                      "%u.%u",
                      v, type_name().c_str(), static_cast<unsigned>(kVersionMajor),
                      static_cast<unsigned>(minor_of(static_cast<MessageType>(e.type))),
                      static_cast<unsigned>(kVersionMajor), static_cast<unsigned>(e.version_minor));
      } else {
        std::snprintf(text, sizeof text,
                      "header.type 0x%04llX is not a message type of protocol %u.%u: not "
                      "executed",
                      v, static_cast<unsigned>(kVersionMajor),
                      static_cast<unsigned>(kVersionMinor));
      }
      break;
    case ErrorCode::kBadPayloadLength:
      if (field == "frame") {
        std::snprintf(text, sizeof text, "the bytes given are not exactly one frame");
      } else {
        std::snprintf(text, sizeof text,
                      "header.payload_length is %llu: %s in protocol %u.%u has %s%llu bytes", v,
                      type_name().c_str(), static_cast<unsigned>(kVersionMajor),
                      static_cast<unsigned>(std::min(e.version_minor, kVersionMinor)),
                      e.reason == nullptr ? "" : e.reason, l);
      }
      break;
    case ErrorCode::kInvalidEnumValue:
      if (field == "acknowledged") {
        std::snprintf(text, sizeof text,
                      "acknowledged is 0x%04llX: not a host-to-daemon type of protocol %u.%u", v,
                      static_cast<unsigned>(kVersionMajor),
                      static_cast<unsigned>(std::min(e.version_minor, kVersionMinor)));
      } else if (e.reason != nullptr && std::string_view(e.reason) == "polarity") {
        std::snprintf(text, sizeof text, "%s is %d: a polarity is +1 or -1", field.c_str(),
                      static_cast<int>(static_cast<std::int8_t>(e.value)));
      } else if (e.reason != nullptr && std::string_view(e.reason) == "bool") {
        std::snprintf(text, sizeof text, "%s is %llu: a bool is 0 or 1", field.c_str(), v);
      } else {
        std::snprintf(text, sizeof text, "%s is %llu: allowed values are 0..%llu", field.c_str(), v,
                      l == 0 ? 0 : l - 1);
      }
      break;
    case ErrorCode::kNonFiniteNumber: {
      const double x =
          e.limit == 4
              ? static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(e.value)))
              : std::bit_cast<double>(e.value);
      std::snprintf(text, sizeof text, "%s is %s: numbers on the wire must be finite",
                    field.c_str(), std::isnan(x) ? "NaN" : (x > 0 ? "+infinity" : "-infinity"));
      break;
    }
    case ErrorCode::kBadString:
      std::snprintf(text, sizeof text, "%s: %s (length %llu, capacity %llu)", field.c_str(),
                    e.reason == nullptr ? "bad string" : e.reason, v, l);
      break;
    case ErrorCode::kBadCount:
      std::snprintf(text, sizeof text, "%s is %llu: allowed %zu..%zu", field.c_str(), v,
                    kMinPlanePoints, kMaxPlanePoints);
      break;
    default:
      std::snprintf(text, sizeof text, "%s: %.*s", field.c_str(),
                    static_cast<int>(to_string(e.code).size()), to_string(e.code).data());
      break;
  }
  return text;
}

FrameHeader decode_header(std::span<const std::uint8_t, kHeaderSize> bytes) noexcept {
  const std::uint8_t* h = bytes.data();
  FrameHeader f;
  f.magic = get_u32(h + kOffMagic);
  f.version_major = h[kOffMajor];
  f.version_minor = h[kOffMinor];
  f.type = get_u16(h + kOffType);
  f.flags = get_u16(h + kOffFlags);
  f.request_id = get_u32(h + kOffRequestId);
  f.payload_length = get_u32(h + kOffLength);
  f.crc = get_u32(h + kOffCrc);
  return f;
}

StreamDecoder::Outcome decode_frame(std::span<const std::uint8_t> frame) noexcept {
  StreamDecoder::Outcome out;
  decode_into(frame, out);
  return out;
}

std::size_t StreamDecoder::feed(std::span<const std::uint8_t> in, Outcome& outcome) noexcept {
  outcome.kind = Kind::kNeedMore;
  if (failed_) {
    outcome.kind = Kind::kError;
    outcome.error = failure_;
    return in.size();
  }
  // Fast path: a whole frame at the start of `in` is decoded in place, without copying.
  if (filled_ == 0 && in.size() >= kHeaderSize) {
    const std::uint8_t* h = in.data();
    if (check_header(h, outcome.error)) {
      const std::size_t total = kHeaderSize + get_u32(h + kOffLength);
      if (in.size() >= total) {
        decode_into(in.first(total), outcome, true);
        return total;
      }
    }
    outcome.error = DecodeError{};
  }
  std::size_t used = 0;
  const auto fail = [&](const DecodeError& e) {
    failed_ = true;
    failure_ = e;
    outcome.kind = Kind::kError;
    outcome.error = e;
    return used;
  };
  if (filled_ < kHeaderSize) {
    const std::size_t n = std::min(kHeaderSize - filled_, in.size());
    if (n == 0) return 0;
    std::memcpy(buffer_.data() + filled_, in.data(), n);
    const std::size_t magic_end = std::min(filled_ + n, kMagicBytes.size());
    for (std::size_t i = filled_; i < magic_end; ++i) {
      if (buffer_[i] != kMagicBytes[i]) {
        used = i - filled_ + 1;
        DecodeError e;
        e.code = ErrorCode::kBadMagic;
        e.framing_lost = true;
        e.field = "header.magic";
        return fail(e);
      }
    }
    filled_ += n;
    used = n;
    if (filled_ < kHeaderSize) return used;
    DecodeError e;
    if (!check_header(buffer_.data(), e)) return fail(e);
  }
  const std::size_t total = kHeaderSize + get_u32(buffer_.data() + kOffLength);
  const std::size_t n = std::min(total - filled_, in.size() - used);
  if (n > 0) std::memcpy(buffer_.data() + filled_, in.data() + used, n);
  filled_ += n;
  used += n;
  if (filled_ < total) return used;
  decode_into(std::span<const std::uint8_t>(buffer_.data(), total), outcome);
  filled_ = 0;
  return used;
}

void StreamDecoder::reset() noexcept {
  filled_ = 0;
  failed_ = false;
  failure_ = DecodeError{};
}

}  // namespace ajar::protocol
