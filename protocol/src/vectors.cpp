#include "ajar/protocol/vectors.hpp"

#include <algorithm>
#include <array>
#include <cstring>

#include "ajar/protocol/codec.hpp"

namespace ajar::protocol {

namespace {

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

Error syntax(std::size_t line, std::string field, std::string_view what) {
  return make_error(ErrorCode::kBadString, std::move(field),
                    "line " + std::to_string(line) + ": " + std::string(what));
}

Error mismatch(const GoldenVector& v, const std::string& what) {
  return make_error(ErrorCode::kInternal, v.name, "vector " + v.name + ": " + what);
}

std::string describe(const StreamDecoder::Outcome& o) {
  switch (o.kind) {
    case StreamDecoder::Kind::kNeedMore:
      return "need more bytes";
    case StreamDecoder::Kind::kMessage:
      return "message " + std::string(to_string(type_of(o.envelope.message)));
    case StreamDecoder::Kind::kError:
      return "error " + std::string(to_string(o.error.code)) +
             (o.error.framing_lost ? " framing_lost" : "") + " field '" + o.error.field + "'";
  }
  return "?";
}

bool same_outcome(const StreamDecoder::Outcome& a, const StreamDecoder::Outcome& b) {
  if (a.kind != b.kind) return false;
  if (a.kind == StreamDecoder::Kind::kError) {
    return a.error.code == b.error.code && a.error.framing_lost == b.error.framing_lost &&
           std::strcmp(a.error.field, b.error.field) == 0 &&
           a.error.request_id == b.error.request_id && a.error.type == b.error.type;
  }
  if (a.kind == StreamDecoder::Kind::kMessage) {
    return a.envelope.request_id == b.envelope.request_id && a.envelope.flags == b.envelope.flags &&
           wire_equal(a.envelope.message, b.envelope.message);
  }
  return true;
}

// Feeds `bytes` one at a time; returns the outcomes produced.
std::vector<StreamDecoder::Outcome> feed_bytewise(std::span<const std::uint8_t> bytes) {
  StreamDecoder decoder;
  std::vector<StreamDecoder::Outcome> outcomes;
  StreamDecoder::Outcome o;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const std::size_t used = decoder.feed(bytes.subspan(i, 1), o);
    if (o.kind != StreamDecoder::Kind::kNeedMore) {
      outcomes.push_back(o);
      if (o.kind == StreamDecoder::Kind::kError && o.error.framing_lost) break;
    }
    if (used != 1) break;
  }
  return outcomes;
}

// The values of a vector's keys, each into `v`; `line` is the line's number for the error.
Outcome parse_direction(std::string_view value, std::size_t line, GoldenVector& v) {
  if (value == "host_to_daemon") {
    v.direction = GoldenVector::Direction::kHostToDaemon;
  } else if (value == "daemon_to_host") {
    v.direction = GoldenVector::Direction::kDaemonToHost;
  } else {
    return syntax(line, "direction", "expected host_to_daemon or daemon_to_host");
  }
  return Ok{};
}

// "ok", or "error CODE [framing_lost]".
Outcome parse_expect(std::string_view value, std::size_t line, GoldenVector& v) {
  if (value == "ok") {
    v.expect_ok = true;
    return Ok{};
  }
  if (!value.starts_with("error")) {
    return syntax(line, "expect", "expected 'ok' or 'error CODE [framing_lost]'");
  }
  v.expect_ok = false;
  std::string_view rest = trim(value.substr(5));
  const auto space = rest.find_first_of(" \t");
  const std::string_view code = rest.substr(0, space);
  const std::string_view tail =
      space == std::string_view::npos ? std::string_view{} : trim(rest.substr(space));
  const auto parsed = error_code_from_string(code);
  if (!parsed || *parsed == ErrorCode::kOk) {
    return syntax(line, "expect", "unknown error code '" + std::string(code) + "'");
  }
  v.expected_error = *parsed;
  if (tail == "framing_lost") {
    v.framing_lost = true;
  } else if (!tail.empty()) {
    return syntax(line, "expect", "expected 'framing_lost' after the error code");
  }
  return Ok{};
}

Outcome parse_roundtrip(std::string_view value, std::size_t line, GoldenVector& v) {
  if (value == "yes") {
    v.roundtrip = true;
  } else if (value == "no") {
    v.roundtrip = false;
  } else {
    return syntax(line, "roundtrip", "expected yes or no");
  }
  return Ok{};
}

// One line of hex digits (spaces and tabs between them ignored), appended to the vector's bytes.
Outcome parse_hex(std::string_view value, std::size_t line, GoldenVector& v) {
  int high = -1;
  for (const char c : value) {
    if (c == ' ' || c == '\t') continue;
    const int d = hex_digit(c);
    if (d < 0) return syntax(line, "hex", "not a hex digit");
    if (high < 0) {
      high = d;
    } else {
      v.bytes.push_back(static_cast<std::uint8_t>(high * 16 + d));
      high = -1;
    }
  }
  if (high >= 0) return syntax(line, "hex", "odd number of hex digits on the line");
  return Ok{};
}

}  // namespace

Result<GoldenVector> parse_vector(std::string_view text) {
  GoldenVector v;
  bool have_name = false, have_direction = false, have_expect = false, have_hex = false;
  std::size_t line_no = 0;
  while (!text.empty()) {
    const auto end = text.find('\n');
    const std::string_view raw = text.substr(0, end);
    text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
    ++line_no;
    const std::string_view line = trim(raw);
    if (line.empty() || line.front() == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string_view::npos) return syntax(line_no, "line", "expected 'key: value'");
    const std::string_view key = trim(line.substr(0, colon));
    const std::string_view value = trim(line.substr(colon + 1));
    Outcome parsed = Ok{};
    if (key == "name") {
      if (value.empty()) return syntax(line_no, "name", "empty name");
      v.name = std::string(value);
      have_name = true;
    } else if (key == "direction") {
      parsed = parse_direction(value, line_no, v);
      have_direction = true;
    } else if (key == "expect") {
      parsed = parse_expect(value, line_no, v);
      have_expect = true;
    } else if (key == "field") {
      v.field = std::string(value);
    } else if (key == "roundtrip") {
      parsed = parse_roundtrip(value, line_no, v);
    } else if (key == "hex") {
      parsed = parse_hex(value, line_no, v);
      have_hex = true;
    }
    // Unknown keys are ignored.
    if (!parsed) return std::move(parsed).error();
  }
  if (!have_name) return syntax(line_no, "name", "missing 'name:'");
  if (!have_direction) return syntax(line_no, "direction", "missing 'direction:'");
  if (!have_expect) return syntax(line_no, "expect", "missing 'expect:'");
  if (!have_hex) return syntax(line_no, "hex", "missing 'hex:'");
  return v;
}

std::string format_vector(const GoldenVector& v, std::string_view comment) {
  std::string out;
  while (!comment.empty()) {
    const auto end = comment.find('\n');
    out += "# ";
    out += comment.substr(0, end);
    out += '\n';
    comment = end == std::string_view::npos ? std::string_view{} : comment.substr(end + 1);
  }
  out += "name: " + v.name + "\n";
  out += v.direction == GoldenVector::Direction::kHostToDaemon ? "direction: host_to_daemon\n"
                                                               : "direction: daemon_to_host\n";
  if (v.expect_ok) {
    out += "expect: ok\n";
    if (!v.roundtrip) out += "roundtrip: no\n";
  } else {
    out += "expect: error " + std::string(to_string(v.expected_error));
    if (v.framing_lost) out += " framing_lost";
    out += '\n';
    if (!v.field.empty()) out += "field: " + v.field + "\n";
  }
  static constexpr char kHex[] = "0123456789abcdef";
  for (std::size_t i = 0; i < v.bytes.size(); i += 16) {
    out += "hex:";
    for (std::size_t k = i; k < std::min(i + 16, v.bytes.size()); ++k) {
      out += ' ';
      out += kHex[v.bytes[k] >> 4];
      out += kHex[v.bytes[k] & 0xF];
    }
    out += '\n';
  }
  if (v.bytes.empty()) out += "hex:\n";
  return out;
}

Outcome check_vector(const GoldenVector& v) {
  const StreamDecoder::Outcome whole = decode_frame(v.bytes);
  const auto streamed = feed_bytewise(v.bytes);
  if (streamed.empty()) return mismatch(v, "the stream decoder produced nothing");
  if (!same_outcome(whole, streamed.front())) {
    return mismatch(v, "decode_frame gave " + describe(whole) + " but the stream decoder gave " +
                           describe(streamed.front()));
  }
  if (v.expect_ok) {
    if (whole.kind != StreamDecoder::Kind::kMessage) {
      return mismatch(v, "expected a message, got " + describe(whole));
    }
    const bool request = is_request(type_of(whole.envelope.message));
    if (request != (v.direction == GoldenVector::Direction::kHostToDaemon)) {
      return mismatch(v, "message type does not match the direction");
    }
    // Re-encoded in the frame's own layout (a 1.0 frame as 1.0; a newer minor's as ours).
    std::array<std::uint8_t, kMaxFrameSize> out{};
    const std::size_t n = encode(whole.envelope, out, std::min(v.bytes[5], kVersionMinor));
    if (n == 0) return mismatch(v, "the decoded message does not re-encode");
    const std::span<const std::uint8_t> again(out.data(), n);
    if (v.roundtrip) {
      if (!std::equal(again.begin(), again.end(), v.bytes.begin(), v.bytes.end())) {
        return mismatch(v, "re-encoding does not reproduce the bytes");
      }
    } else {
      const auto second = decode_frame(again);
      if (!same_outcome(whole, second))
        return mismatch(v, "re-encoded message decodes differently");
    }
    return Ok{};
  }
  if (whole.kind != StreamDecoder::Kind::kError) {
    return mismatch(v, "expected error " + std::string(to_string(v.expected_error)) + ", got " +
                           describe(whole));
  }
  if (whole.error.code != v.expected_error || whole.error.framing_lost != v.framing_lost ||
      (!v.field.empty() && v.field != whole.error.field)) {
    return mismatch(v, "expected error " + std::string(to_string(v.expected_error)) +
                           (v.framing_lost ? " framing_lost" : "") +
                           (v.field.empty() ? "" : " field '" + v.field + "'") + ", got " +
                           describe(whole));
  }
  if (!v.framing_lost) {
    // The stream must continue with the next frame.
    std::vector<std::uint8_t> stream = v.bytes;
    if (!encode_append(Envelope{7, 0, Ping{42}}, stream)) return mismatch(v, "encode Ping");
    const auto outcomes = feed_bytewise(stream);
    if (outcomes.size() != 2 || outcomes[1].kind != StreamDecoder::Kind::kMessage ||
        !std::holds_alternative<Ping>(outcomes[1].envelope.message) ||
        outcomes[1].envelope.request_id != 7) {
      return mismatch(v, "the stream did not continue with the next frame after the error");
    }
  }
  return Ok{};
}

}  // namespace ajar::protocol
