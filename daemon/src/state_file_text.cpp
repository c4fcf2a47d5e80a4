// The state file's text formats 1 and 2 (ajard before format 3), read once: a start on such a
// file restores it and the engine's first save rewrites it in format 3 (state_store.hpp). Nothing
// writes them any more. Their checksum is a CRC-32 (Boost.CRC) over every byte before the
// `crc32` line; the layout, line by line:
//   ajar-state 1|2
//   clean_shutdown 0|1                                   (version 2; absent in version 1)
//   phase idle|aligning|engaging|engaged
//   aligned 0|1
//   plane_consumed 0|1
//   fault <numeric ErrorCode>
//   width <frame> <x> <y> <z> <frame> <x> <y> <z>       (optional; frame: camera|base)
//   handle <frame> <x> <y> <z> <frame> <x> <y> <z>      (optional)
//   plane <n> then n times <frame> <x> <y> <z>          (optional)
//   contact <frame> <x> <y> <z>                         (optional)
//   crc32 <8 hex digits>
#include <charconv>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <boost/crc.hpp>

#include "state_file.hpp"

namespace ajar::daemon::detail {
namespace {

constexpr const char* kTextMagic = "ajar-state";

std::uint32_t crc32(std::string_view bytes) {
  boost::crc_32_type crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

// Whitespace-separated tokens of one line.
class Tokens {
 public:
  explicit Tokens(const std::string& line) {
    std::istringstream in(line);
    std::string t;
    while (in >> t)
      tokens_.push_back(t);
  }
  std::size_t size() const { return tokens_.size(); }
  const std::string& operator[](std::size_t i) const { return tokens_[i]; }

 private:
  std::vector<std::string> tokens_;
};

// Finite numbers only: "nan", "inf" and out-of-range values are refused.
bool parse_double(const std::string& s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(v);
}

bool parse_int(const std::string& s, long long& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Parses "<frame> x y z" starting at token `at`.
bool parse_point(const Tokens& t, std::size_t at, core::FramedPoint& p) {
  if (at + 4 > t.size()) return false;
  if (t[at] == "camera")
    p.frame = core::Frame::kCamera;
  else if (t[at] == "base")
    p.frame = core::Frame::kBase;
  else
    return false;
  for (int i = 0; i < 3; ++i) {
    double v = 0;
    if (!parse_double(t[at + 1 + static_cast<std::size_t>(i)], v)) return false;
    p.position_m[i] = v;
  }
  return true;
}

// The bytes before the `crc32` line, when its checksum is theirs.
Result<std::string> checksummed_body(const std::string& text) {
  const auto crc_at = text.rfind("crc32 ");
  if (crc_at == std::string::npos || (crc_at > 0 && text[crc_at - 1] != '\n')) {
    return state_file_error("no checksum line (truncated?)");
  }
  std::string body = text.substr(0, crc_at);
  const Tokens crc_line(text.substr(crc_at));
  unsigned long expected = 0;
  if (crc_line.size() != 2 ||
      std::from_chars(crc_line[1].data(), crc_line[1].data() + crc_line[1].size(), expected, 16)
              .ec != std::errc() ||
      expected != crc32(body)) {
    return state_file_error("checksum mismatch (corrupt file)");
  }
  return body;
}

// What is wrong with a line (its number is added by the caller); none when it was read.
using LineError = std::optional<std::string>;

// `ajar-state 1|2`: the file's format version.
LineError read_header(const Tokens& t, StateRecord& state) {
  if (t.size() != 2 || t[0] != kTextMagic) return "not an ajar state file";
  if (t[1] != "1" && t[1] != "2") {
    return "unsupported format version " + t[1] + " (this daemon reads 1, 2 and " +
           std::to_string(kStateFormatVersion) + ")";
  }
  state.format_version = t[1] == "1" ? 1 : 2;
  return std::nullopt;
}

LineError read_phase(const std::string& word, Phase& phase) {
  if (word == "idle")
    phase = Phase::kIdle;
  else if (word == "aligning")
    phase = Phase::kAligning;
  else if (word == "engaging")
    phase = Phase::kEngaging;
  else if (word == "engaged")
    phase = Phase::kEngaged;
  else
    return "unknown phase '" + word + "'";
  return std::nullopt;
}

// `plane <n>` then n points, n within what MeasureDoorPlane carries.
LineError read_plane(const Tokens& t, ProcedureRecord& r) {
  long long n = 0;
  if (!parse_int(t[1], n) || n < static_cast<long long>(protocol::kMinPlanePoints) ||
      n > static_cast<long long>(protocol::kMaxPlanePoints) ||
      t.size() != 2 + 4 * static_cast<std::size_t>(n)) {
    return "bad plane point count";
  }
  protocol::MeasureDoorPlane m;
  m.count = static_cast<std::uint8_t>(n);
  for (std::size_t i = 0; i < m.count; ++i) {
    if (!parse_point(t, 2 + 4 * i, m.points[i])) return "bad plane point";
  }
  r.plane = m;
  return std::nullopt;
}

// One line after the header (its key not seen before): the procedure's fields, the clean
// shutdown flag (format 2) and the measurements.
LineError read_field(const Tokens& t, const std::string& line, StateRecord& state) {
  ProcedureRecord& r = state.procedure;
  const std::string& key = t[0];
  if (key == "clean_shutdown" && state.format_version >= 2 && t.size() == 2 &&
      (t[1] == "0" || t[1] == "1")) {
    state.clean_shutdown = t[1] == "1";
  } else if (key == "phase" && t.size() == 2) {
    return read_phase(t[1], r.phase);
  } else if ((key == "aligned" || key == "plane_consumed") && t.size() == 2 &&
             (t[1] == "0" || t[1] == "1")) {
    (key == "aligned" ? r.aligned : r.plane_consumed) = t[1] == "1";
  } else if (key == "fault" && t.size() == 2) {
    long long code = 0;
    if (!parse_int(t[1], code) || !is_restorable_fault(code)) {
      return "fault code '" + t[1] + "' is not a fault the daemon latches";
    }
    r.fault = static_cast<ErrorCode>(code);
  } else if (key == "width" && t.size() == 9) {
    protocol::MeasureDoorWidth m;
    if (!parse_point(t, 1, m.p1_hinge) || !parse_point(t, 5, m.p2_moving_edge)) {
      return "bad width points";
    }
    r.width = m;
  } else if (key == "handle" && t.size() == 9) {
    protocol::MeasureHandle m;
    if (!parse_point(t, 1, m.p1_axis) || !parse_point(t, 5, m.p2_free_end)) {
      return "bad handle points";
    }
    r.handle = m;
  } else if (key == "plane" && t.size() >= 2) {
    return read_plane(t, r);
  } else if (key == "contact" && t.size() == 5) {
    protocol::SetContactPoint m;
    if (!parse_point(t, 1, m.contact)) return "bad contact point";
    r.contact = m;
  } else {
    return "unexpected '" + line + "'";
  }
  return std::nullopt;
}

}  // namespace

Result<StateRecord> decode_text_state(const std::string& text) {
  const Result<std::string> body = checksummed_body(text);
  if (!body) return body.error();
  StateRecord state;
  std::istringstream in(*body);
  std::string line;
  int line_number = 0;
  bool have_header = false;
  std::set<std::string> seen;
  while (std::getline(in, line)) {
    ++line_number;
    const Tokens t(line);
    if (t.size() == 0) continue;
    LineError error;
    if (!have_header) {
      error = read_header(t, state);
      have_header = !error;
    } else if (!seen.insert(t[0]).second) {
      error = "'" + t[0] + "' appears twice";
    } else {
      error = read_field(t, line, state);
    }
    if (error) return state_file_error("line " + std::to_string(line_number) + ": " + *error);
  }
  if (!have_header) return state_file_error("empty file");
  for (const char* required : {"clean_shutdown", "phase", "aligned", "plane_consumed", "fault"}) {
    if (state.format_version < 2 && std::string_view(required) == "clean_shutdown") continue;
    if (seen.count(required) == 0)
      return state_file_error(std::string("line '") + required + "' missing");
  }
  return state;
}

}  // namespace ajar::daemon::detail
