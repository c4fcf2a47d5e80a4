// Golden vectors: one frame (valid or not) with what a decoder must make of it. Stored as small
// text files (*.vec) in tests/conformance/vectors/, readable by any implementation:
//
//   # comment lines (also blank lines) are ignored
//   name: hello_controller
//   direction: host_to_daemon            (or daemon_to_host: who sends this frame)
//   expect: ok                           (or: expect: error CRC_MISMATCH [framing_lost])
//   field: points[2].frame               (optional, errors only: DecodeError::field must match)
//   roundtrip: no                        (optional, ok only; default yes: re-encoding the decoded
//                                         message must reproduce the bytes exactly)
//   hex: 41 4a 41 52 ...                 (one or more hex: lines, concatenated; whitespace free)
//
// Unknown keys are ignored (forward compatible). Pure: parsing and checking only; the caller reads
// the files.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/core/result.hpp"

namespace ajar::protocol {

struct GoldenVector {
  enum class Direction { kHostToDaemon, kDaemonToHost };
  std::string name;
  Direction direction = Direction::kHostToDaemon;
  bool expect_ok = true;
  ErrorCode expected_error = ErrorCode::kOk;  // when !expect_ok
  bool framing_lost = false;                  // when !expect_ok
  std::string field;                          // when !expect_ok; empty = not checked
  bool roundtrip = true;                      // when expect_ok
  std::vector<std::uint8_t> bytes;
};

// Parses one vector file's text. Errors: kBadString with field = the key (or "line") and a message
// naming the line number.
Result<GoldenVector> parse_vector(std::string_view text);

// The text form of `v` (parse_vector(format_vector(v)) == v). `comment` becomes '# ' lines on top.
std::string format_vector(const GoldenVector& v, std::string_view comment = {});

// Checks this library against `v`: decode_frame() and a StreamDecoder fed one byte at a time must
// both give the expected outcome; a valid frame must re-encode byte-exact in the layout of its
// header's minor version (or, with roundtrip: no,
// to a message that is wire_equal), and its type must match the direction; an error that does not
// lose framing must skip exactly this frame (a Ping appended after it still decodes).
// Error on mismatch: kInternal with a message saying what differed.
Outcome check_vector(const GoldenVector& v);

}  // namespace ajar::protocol
