// Regenerates the golden vectors: ajar_protocol_vector_gen tests/conformance/vectors
// Valid vectors are the encoded samples (samples.hpp); invalid ones patch a valid frame (and,
// unless the CRC is the point, recompute its CRC). The committed .vec files are the source of
// truth: only regenerate when the protocol deliberately changes, and review the diff.
#include <bit>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>

#include "ajar/protocol/layout.hpp"
#include "ajar/protocol/vectors.hpp"
#include "samples.hpp"

namespace {

using ajar::ErrorCode;
using namespace ajar::protocol;
using Bytes = std::vector<std::uint8_t>;

const samples::Sample& sample(const std::string& name) {
  static const std::vector<samples::Sample> all = samples::all();
  for (const auto& s : all) {
    if (s.name == name) return s;
  }
  throw std::runtime_error("no sample " + name);
}

// In the sample's vector minor (samples::vector_minor) unless told otherwise.
Bytes encode_sample(const std::string& name, int minor = -1) {
  Bytes out;
  const Message& m = sample(name).envelope.message;
  if (!encode_append(sample(name).envelope, out,
                     minor < 0 ? samples::vector_minor(m) : static_cast<std::uint8_t>(minor))) {
    throw std::runtime_error("cannot encode " + name);
  }
  return out;
}

void put_u16(Bytes& b, std::size_t at, std::uint16_t v) {
  b[at] = static_cast<std::uint8_t>(v);
  b[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(Bytes& b, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i)
    b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
// Sets the payload length from the buffer size and recomputes the CRC.
void refresh(Bytes& b) {
  put_u32(b, kOffsetPayloadLength, static_cast<std::uint32_t>(b.size() - kHeaderSize));
  Bytes covered(b.begin(), b.begin() + kOffsetCrc);
  covered.insert(covered.end(), b.begin() + static_cast<std::ptrdiff_t>(kHeaderSize), b.end());
  put_u32(b, kOffsetCrc, crc32c(covered));
}
void put_f64(Bytes& b, std::size_t at, double v) {
  const auto u = std::bit_cast<std::uint64_t>(v);
  for (std::size_t i = 0; i < 8; ++i)
    b[at + i] = static_cast<std::uint8_t>(u >> (8 * i));
}

struct Written {
  GoldenVector vector;
  std::string comment;
};

// A refused frame: the sample `base` with `patch` applied. `at` is the frame offset of `field`
// in the sample (payload_layout(), the codec's own tables), so the field a vector corrupts and
// the field the decoder must name are one fact; header fields are patched at fixed offsets.
struct BadVector {
  std::vector<Written>& out;
  void operator()(std::string name, std::string base, ErrorCode code, bool framing_lost,
                  std::string field, const std::function<void(Bytes&, std::size_t at)>& patch,
                  std::string comment) const {
    GoldenVector v;
    v.name = std::move(name);
    v.expect_ok = false;
    v.expected_error = code;
    v.framing_lost = framing_lost;
    v.bytes = encode_sample(base);
    const Message& m = sample(base).envelope.message;
    v.direction = is_request(type_of(m)) ? GoldenVector::Direction::kHostToDaemon
                                         : GoldenVector::Direction::kDaemonToHost;
    const std::ptrdiff_t offset = offset_of(m, field);
    if (!field.starts_with("header.") && offset < 0) {
      throw std::runtime_error(base + " has no field " + field);
    }
    patch(v.bytes, offset < 0 ? 0 : kHeaderSize + static_cast<std::size_t>(offset));
    v.field = std::move(field);
    out.push_back({v, std::move(comment)});
  }
};
constexpr std::size_t P = kHeaderSize;  // payload offset

// Every sample, byte-exact; the 1.0 layouts; a newer minor's appended field.
void good_vectors(std::vector<Written>& out) {
  for (const auto& s : samples::all()) {
    GoldenVector v;
    v.name = s.name;
    v.direction = is_request(type_of(s.envelope.message)) ? GoldenVector::Direction::kHostToDaemon
                                                          : GoldenVector::Direction::kDaemonToHost;
    v.bytes = encode_sample(s.name);
    out.push_back({v, std::string(to_string(type_of(s.envelope.message))) + ", request id " +
                          std::to_string(s.envelope.request_id) + ". Decodes and re-encodes " +
                          "byte-exact."});
  }

  // A 1.0 peer's frames: the 1.0 layout of the types that 1.1 extended.
  for (const char* name : {"welcome", "status", "telemetry"}) {
    GoldenVector v;
    v.name = std::string("v1_0_") + name;
    v.direction = GoldenVector::Direction::kDaemonToHost;
    v.bytes = encode_sample(name, 0);
    out.push_back({v, std::string("The ") + name +
                          " sample as protocol 1.0 sends it (header minor 0, the 1.0 layout: "
                          "the fields 1.1 appended are absent). Decodes; 1.1 fields read as 0."});
  }

  // 1.2's Status: base_motion and the recorder's state appended.
  {
    GoldenVector v;
    v.name = "v1_2_status";
    v.direction = GoldenVector::Direction::kDaemonToHost;
    v.bytes = encode_sample("status", 2);
    out.push_back({v,
                   "The status sample as protocol 1.2 sends it (header minor 2): base_motion "
                   "(approaching) and recorder (RecorderState) appended to the 1.1 layout."});
  }

  // A newer minor version may append fields: older decoders ignore the tail.
  {
    GoldenVector v;
    v.name = "newer_minor_appended_field";
    v.roundtrip = false;
    v.bytes = encode_sample("ping");
    v.bytes[kOffsetVersionMinor] = 3;  // version 1.3 (newer than this library's 1.1)
    for (const std::uint8_t x : Bytes{0xDE, 0xAD, 0xBE, 0xEF})
      v.bytes.push_back(x);
    refresh(v.bytes);
    out.push_back({v,
                   "Ping sent by a v1.3 peer with 4 appended payload bytes: accepted, tail "
                   "ignored.\nRe-encoding gives the v1.1 frame (roundtrip: no)."});
  }
}

// Refused headers: framing lost (magic, version, size) or one frame skipped.
void header_vectors(std::vector<Written>& out) {
  const BadVector bad{out};
  bad(
      "bad_magic", "ping", ErrorCode::kBadMagic, true, "header.magic",
      [](Bytes& b, std::size_t) { b[kOffsetMagic + 3] = 'X'; },
      "Magic \"AJAX\" instead of \"AJAR\": framing lost, close.");
  bad(
      "unsupported_version", "ping", ErrorCode::kUnsupportedVersion, true, "header.version_major",
      [](Bytes& b, std::size_t) {
        b[kOffsetVersionMajor] = 2;
        refresh(b);
      },
      "Major version 2: reply UNSUPPORTED_VERSION, then close.");
  bad(
      "payload_too_large", "ping", ErrorCode::kPayloadTooLarge, true, "header.payload_length",
      [](Bytes& b, std::size_t) {
        b.resize(kHeaderSize);
        put_u32(b, kOffsetPayloadLength, 1025);
      },
      "Header announces 1025 payload bytes (max 1024): refused before reading the payload;\n"
      "framing lost. The vector is the header only.");
  bad(
      "crc_mismatch", "measure_door_width", ErrorCode::kCrcMismatch, false, "header.crc",
      [](Bytes& b, std::size_t) { b[P + 3] ^= 0x01; },
      "One payload bit flipped; the CRC no longer matches.");
  bad(
      "crc_mismatch_header", "ping", ErrorCode::kCrcMismatch, false, "header.crc",
      [](Bytes& b, std::size_t) { b[kOffsetRequestId] ^= 0x80; },
      "Request id bit flipped: the CRC covers the header too.");
  bad(
      "bad_payload_length_short", "ping", ErrorCode::kBadPayloadLength, false,
      "header.payload_length",
      [](Bytes& b, std::size_t) {
        b.pop_back();
        refresh(b);
      },
      "Ping with a 7-byte payload (needs 8).");
  bad(
      "bad_payload_length_long", "stop", ErrorCode::kBadPayloadLength, false,
      "header.payload_length",
      [](Bytes& b, std::size_t) {
        b.push_back(0);
        refresh(b);
      },
      "Stop with a 1-byte payload (needs 0; only a newer minor may append).");
  bad(
      "bad_payload_length_plane", "measure_door_plane_3", ErrorCode::kBadPayloadLength, false,
      "header.payload_length",
      [](Bytes& b, std::size_t) {
        b[P] = 4;  // count says 4 points, payload holds 3
        refresh(b);
      },
      "MeasureDoorPlane with count 4 but three points of payload.");
  bad(
      "unknown_message_type", "stop", ErrorCode::kUnknownMessageType, false, "header.type",
      [](Bytes& b, std::size_t) {
        put_u16(b, kOffsetType, 0x0199);
        refresh(b);
      },
      "Type 0x0199 is not defined in v1: reply UNKNOWN_MESSAGE_TYPE, session continues.");
  bad(
      "unknown_flags", "ping", ErrorCode::kUnknownFlags, false, "header.flags",
      [](Bytes& b, std::size_t) {
        put_u16(b, kOffsetFlags, 0x8001);
        refresh(b);
      },
      "Reserved flag bit 15 set: refused with UNKNOWN_FLAGS, not executed, session continues.");
}

// Refused payloads: enum values.
void enum_vectors(std::vector<Written>& out) {
  const BadVector bad{out};
  bad(
      "invalid_enum_plane_frame", "measure_door_plane_3", ErrorCode::kInvalidEnumValue, false,
      "points[2].frame",
      [](Bytes& b, std::size_t at) {
        b[at] = 7;
        refresh(b);
      },
      "Third plane point names frame 7 (only 0 camera, 1 base exist).");
  bad(
      "invalid_enum_hello_role", "hello_controller", ErrorCode::kInvalidEnumValue, false,
      "requested_role",
      [](Bytes& b, std::size_t at) {
        b[at] = 2;
        refresh(b);
      },
      "Hello asks for role 2.");
  bad(
      "invalid_enum_bool", "reset", ErrorCode::kInvalidEnumValue, false, "clear_parameters",
      [](Bytes& b, std::size_t at) {
        b[at] = 2;
        refresh(b);
      },
      "Booleans are 0 or 1.");
  bad(
      "invalid_enum_ack_acknowledged", "ack_align_base", ErrorCode::kInvalidEnumValue, false,
      "acknowledged",
      [](Bytes& b, std::size_t at) {
        put_u16(b, at, 0x0201);
        refresh(b);
      },
      "Ack acknowledging a Welcome (not a request type).");
}

// Refused payloads: numbers, counts, strings.
void value_vectors(std::vector<Written>& out) {
  const BadVector bad{out};
  bad(
      "non_finite_nan", "measure_door_width", ErrorCode::kNonFiniteNumber, false, "p2.z",
      [](Bytes& b, std::size_t at) {
        put_f64(b, at, std::numeric_limits<double>::quiet_NaN());
        refresh(b);
      },
      "P2's z (depth) is NaN.");
  bad(
      "non_finite_infinity", "subscribe", ErrorCode::kNonFiniteNumber, false, "telemetry_rate_hz",
      [](Bytes& b, std::size_t at) {
        put_u32(b, at, 0x7F800000);
        refresh(b);
      },
      "Subscribe at +infinity Hz.");
  bad(
      "bad_count_low", "measure_door_plane_3", ErrorCode::kBadCount, false, "count",
      [](Bytes& b, std::size_t at) {
        b[at] = 2;
        b.resize(at + 1 + 2 * 25);  // count, then two 25-byte points
        refresh(b);
      },
      "Door plane with 2 points (3..16).");
  bad(
      "bad_count_high", "measure_door_plane_16", ErrorCode::kBadCount, false, "count",
      [](Bytes& b, std::size_t at) {
        b[at] = 17;
        refresh(b);
      },
      "Door plane with count 17 (3..16).");
  bad(
      "bad_string_too_long", "hello_controller", ErrorCode::kBadString, false, "client_name",
      [](Bytes& b, std::size_t at) {
        b[at] = 33;
        refresh(b);
      },
      "client_name length 33 (capacity 32).");
  bad(
      "bad_string_padding", "hello_controller", ErrorCode::kBadString, false, "client_name",
      [](Bytes& b, std::size_t at) {
        b[at + 1 + 31] = 'x';  // the last byte of the 32
        refresh(b);
      },
      "Bytes after client_name's length must be zero.");
  bad(
      "bad_string_utf8", "error_points_collinear", ErrorCode::kBadString, false, "message",
      [](Bytes& b, std::size_t at) {
        b[at + 1] = 0xC3;
        b[at + 2] = 0x28;
        refresh(b);
      },
      "Error.message starting with an invalid UTF-8 sequence (C3 28).");
  bad(
      "bad_string_control", "hello_controller", ErrorCode::kBadString, false, "client_name",
      [](Bytes& b, std::size_t at) {
        b[at + 1 + 4] = '\n';
        refresh(b);
      },
      "Control characters (U+0000..U+001F, U+007F) are not allowed in strings.");
}

// Refused by version: 1.0 layouts and types, and 1.2 types in a 1.1 frame.
void version_vectors(std::vector<Written>& out) {
  const BadVector bad{out};
  bad(
      "v1_0_status_with_1_1_length", "status", ErrorCode::kBadPayloadLength, false,
      "header.payload_length",
      [](Bytes& b, std::size_t) {
        b[kOffsetVersionMinor] = 0;
        refresh(b);
      },
      "A Status frame that says 1.0 but carries the 1.1 layout: a 1.0 frame must have the 1.0\n"
      "length exactly (only a NEWER minor may be longer).");
  bad(
      "v1_0_drive", "drive", ErrorCode::kUnknownMessageType, false, "header.type",
      [](Bytes& b, std::size_t) {
        b[kOffsetVersionMinor] = 0;
        refresh(b);
      },
      "Drive (0x0122) in a frame that says 1.0: 1.0 has no such type.");
  // 1.2: the black box.
  bad(
      "v1_1_fetch_recording", "fetch_recording", ErrorCode::kUnknownMessageType, false,
      "header.type",
      [](Bytes& b, std::size_t) {
        b[5] = 1;
        refresh(b);
      },
      "FetchRecording (0x0151) in a frame that says 1.1: 1.1 has no such type.");
}

// Refused 1.2 payloads: the black box's chunks, lists, names and durations.
void black_box_vectors(std::vector<Written>& out) {
  const BadVector bad{out};
  bad(
      "bad_bytes_length", "recording_chunk", ErrorCode::kBadCount, false, "data",
      [](Bytes& b, std::size_t at) {
        put_u16(b, at, 961);
        refresh(b);
      },
      "RecordingChunk whose data length is 961 (capacity 960).");
  bad(
      "bad_bytes_padding", "recording_chunk", ErrorCode::kBadCount, false, "data",
      [](Bytes& b, std::size_t at) {
        b[at + 2 + 959] = 0x01;  // the last of the 960 bytes, past the 424 of data
        refresh(b);
      },
      "Bytes after RecordingChunk's data length must be zero.");
  bad(
      "bad_count_recording_list", "recording_list", ErrorCode::kBadCount, false, "count",
      [](Bytes& b, std::size_t at) {
        b[at] = 9;
        refresh(b);
      },
      "RecordingList announcing 9 entries (it has 8).");
  bad(
      "bad_string_recording_name", "fetch_recording", ErrorCode::kBadString, false, "name",
      [](Bytes& b, std::size_t at) {
        b[at + 1] = '/';  // allowed by the codec: the daemon refuses it (a file name, no path)
        b[at + 1 + 2] = 0x7F;
        refresh(b);
      },
      "FetchRecording whose name holds a control character (U+007F).");
  bad(
      "non_finite_save_recording", "save_recording", ErrorCode::kNonFiniteNumber, false, "last_s",
      [](Bytes& b, std::size_t at) {
        put_u32(b, at, 0x7FC00000);
        refresh(b);
      },
      "SaveRecording of the last NaN seconds.");
}

// Refused values of the robot and its motion: RobotModel's wheel polarity, Welcome's driver kind,
// Drive and Approach.
void robot_and_drive_vectors(std::vector<Written>& out) {
  const BadVector bad{out};
  bad(
      "invalid_polarity", "robot_model", ErrorCode::kInvalidEnumValue, false, "left.polarity",
      [](Bytes& b, std::size_t at) {
        b[at] = 0;
        refresh(b);
      },
      "RobotModel with left wheel polarity 0 (only +1 and -1 exist).");
  bad(
      "invalid_enum_driver_kind", "welcome", ErrorCode::kInvalidEnumValue, false, "driver_kind",
      [](Bytes& b, std::size_t at) {
        b[at] = 3;
        refresh(b);
      },
      "Welcome with driver_kind 3 (0 sim, 1 mock, 2 real).");
  bad(
      "non_finite_drive", "drive", ErrorCode::kNonFiniteNumber, false, "angular_rad_s",
      [](Bytes& b, std::size_t at) {
        put_f64(b, at, -std::numeric_limits<double>::infinity());
        refresh(b);
      },
      "Drive with angular velocity -infinity.");
  bad(
      "bad_payload_length_approach", "approach", ErrorCode::kBadPayloadLength, false,
      "header.payload_length",
      [](Bytes& b, std::size_t) {
        b.erase(b.end() - 4, b.end());  // (resize(size - 4) trips GCC 12's -Wstringop-overflow)
        refresh(b);
      },
      "Approach with a 4-byte payload (needs 8).");
}

// Each vector self-checked, then written as DIR/NAME.vec. The exit code of main.
int write_vectors(const std::string& dir, const std::vector<Written>& out) {
  int failures = 0;
  for (const auto& w : out) {
    const auto check = check_vector(w.vector);
    if (!check.ok()) {
      std::cerr << "self-check failed: " << check.error().message << "\n";
      ++failures;
    }
    const std::string path = dir + "/" + w.vector.name + ".vec";
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << format_vector(w.vector, w.comment);
    if (!f) {
      std::cerr << "cannot write " << path << "\n";
      return 1;
    }
  }
  std::cout << "wrote " << out.size() << " vectors to " << dir << "\n";
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: ajar_protocol_vector_gen OUTPUT_DIR\n";
    return 2;
  }
  std::vector<Written> out;
  good_vectors(out);
  header_vectors(out);
  enum_vectors(out);
  value_vectors(out);
  version_vectors(out);
  black_box_vectors(out);
  robot_and_drive_vectors(out);
  return write_vectors(argv[1], out);
}
