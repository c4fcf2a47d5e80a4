// State files made by the tests, independently of the daemon's writer (the formats:
// daemon/include/ajar/daemon/state_store.hpp): files that pass the checksum whatever their content,
// for the tests of what the daemon refuses to restore, and the text formats 1 and 2 as older ajard
// wrote them, for the tests of the upgrade.
#pragma once

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>

#include <boost/crc.hpp>

#include "ajar/daemon/state_store.hpp"
#include "ajar/protocol/crc32c.hpp"

namespace ajar::testing {

// Format 1 and 2: a body signed with its CRC-32 line.
inline std::string with_checksum(const std::string& body) {
  boost::crc_32_type crc;
  crc.process_bytes(body.data(), body.size());
  char line[32];
  std::snprintf(line, sizeof(line), "crc32 %08x\n", crc.checksum());
  return body + line;
}

// Format 3: the header's CRC-32C (bytes 18..21, over bytes 0..17) made right again.
inline std::string with_header_crc(std::string bytes) {
  const std::uint32_t crc = protocol::crc32c(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), 18));
  for (std::size_t i = 0; i < 4; ++i)
    bytes[18 + i] = static_cast<char>((crc >> (8 * i)) & 0xFF);
  return bytes;
}

// `record` as ajard wrote it in text format `version` (1: no clean_shutdown line), signed.
inline std::string legacy_text(const daemon::StateRecord& record, int version) {
  const auto number = [](double v) {
    char buffer[64];
    const auto r = std::to_chars(buffer, buffer + sizeof(buffer), v);
    return " " + std::string(buffer, r.ptr);
  };
  const auto point = [&](const core::FramedPoint& p) {
    return std::string(p.frame == core::Frame::kBase ? " base" : " camera") +
           number(p.position_m.x()) + number(p.position_m.y()) + number(p.position_m.z());
  };
  const daemon::ProcedureRecord& r = record.procedure;
  const char* phases[] = {"idle", "aligning", "engaging", "engaged"};
  const auto phase = r.phase == daemon::Phase::kAligning   ? phases[1]
                     : r.phase == daemon::Phase::kEngaging ? phases[2]
                     : r.phase == daemon::Phase::kEngaged  ? phases[3]
                                                           : phases[0];
  std::string out = "ajar-state " + std::to_string(version) + "\n";
  if (version >= 2)
    out += std::string("clean_shutdown ") + (record.clean_shutdown ? "1" : "0") + "\n";
  out += std::string("phase ") + phase + "\n";
  out += std::string("aligned ") + (r.aligned ? "1" : "0") + "\n";
  out += std::string("plane_consumed ") + (r.plane_consumed ? "1" : "0") + "\n";
  out += "fault " + std::to_string(static_cast<unsigned>(r.fault)) + "\n";
  if (r.width) out += "width" + point(r.width->p1_hinge) + point(r.width->p2_moving_edge) + "\n";
  if (r.handle) out += "handle" + point(r.handle->p1_axis) + point(r.handle->p2_free_end) + "\n";
  if (r.plane) {
    out += "plane " + std::to_string(r.plane->count);
    for (std::size_t i = 0; i < r.plane->count; ++i)
      out += point(r.plane->points[i]);
    out += "\n";
  }
  if (r.contact) out += "contact" + point(r.contact->contact) + "\n";
  return with_checksum(out);
}

}  // namespace ajar::testing
