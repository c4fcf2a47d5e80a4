// describe(): the operator's sentence for a decoding failure.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string_view>

#include "ajar/protocol/codec.hpp"

namespace ajar::protocol {

namespace {

std::string dec(std::uint64_t v) {
  return std::to_string(v);
}
std::string hex(std::uint64_t v, int digits) {
  char text[24];
  std::snprintf(text, sizeof text, "0x%0*llX", digits, static_cast<unsigned long long>(v));
  return text;
}
std::string version(std::uint8_t minor) {
  return dec(kVersionMajor) + "." + dec(minor);
}
std::string type_name(std::uint16_t type) {
  const auto t = static_cast<MessageType>(type);
  return minor_of(t) == 255 ? "type " + hex(type, 4) : std::string(to_string(t));
}
std::string unknown_type(const DecodeError& e) {
  const std::uint8_t defined_in = minor_of(static_cast<MessageType>(e.type));
  if (defined_in == 255) {
    return " is not a message type of protocol " + version(kVersionMinor) + ": not executed";
  }
  return " (" + type_name(e.type) + ") is defined from protocol " + version(defined_in) +
         "; the frame says " + version(e.version_minor);
}
// The value of a non-finite number, from its bit pattern (limit: its size in bytes).
std::string non_finite(const DecodeError& e) {
  const double x =
      e.limit == 4 ? static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(e.value)))
                   : std::bit_cast<double>(e.value);
  return std::isnan(x) ? "NaN" : (x > 0 ? "+infinity" : "-infinity");
}
std::string enum_value(const DecodeError& e, const std::string& field, std::uint8_t minor) {
  const std::string_view reason = e.reason == nullptr ? "" : e.reason;
  if (field == "acknowledged") {
    return "acknowledged is " + hex(e.value, 4) + ": not a host-to-daemon type of protocol " +
           version(minor);
  }
  if (reason == "polarity") {
    return field + " is " + std::to_string(static_cast<std::int8_t>(e.value)) +
           ": a polarity is +1 or -1";
  }
  if (reason == "bool") return field + " is " + dec(e.value) + ": a bool is 0 or 1";
  return field + " is " + dec(e.value) + ": allowed values are 0.." +
         dec(e.limit == 0 ? 0 : e.limit - 1);
}

std::string sentence(const DecodeError& e) {
  const std::string field = e.field == nullptr ? "" : e.field;
  const std::string reason = e.reason == nullptr ? "" : e.reason;
  const std::uint8_t minor = std::min(e.version_minor, kVersionMinor);
  switch (e.code) {
    case ErrorCode::kBadMagic:
      return "header.magic: the frame does not start with \"AJAR\" (41 4A 41 52): framing lost, "
             "closing the connection";
    case ErrorCode::kUnsupportedVersion:
      return "header.version_major is " + dec(e.value) + ": this peer speaks protocol " +
             dec(kVersionMajor) + ".x only: closing the connection";
    case ErrorCode::kPayloadTooLarge:
      return "header.payload_length is " + dec(e.value) + ": the maximum is " + dec(e.limit) +
             ": framing lost, closing the connection";
    case ErrorCode::kCrcMismatch:
      return "header.crc is " + hex(e.value, 8) + " but header and payload give " +
             hex(e.limit, 8) + ": frame corrupted, not executed; send it again";
    case ErrorCode::kUnknownFlags:
      return "header.flags is " + hex(e.value, 4) + ": reserved bits set (this version knows " +
             hex(e.limit, 4) + "): not executed";
    case ErrorCode::kUnknownMessageType:
      return "header.type " + hex(e.value, 4) + unknown_type(e);
    case ErrorCode::kBadPayloadLength:
      if (field == "frame") return "the bytes given are not exactly one frame";
      return "header.payload_length is " + dec(e.value) + ": " + type_name(e.type) +
             " in protocol " + version(minor) + " has " + reason + dec(e.limit) + " bytes";
    case ErrorCode::kInvalidEnumValue:
      return enum_value(e, field, minor);
    case ErrorCode::kNonFiniteNumber:
      return field + " is " + non_finite(e) + ": numbers on the wire must be finite";
    case ErrorCode::kBadString:
      return field + ": " + (e.reason == nullptr ? "bad string" : reason) + " (length " +
             dec(e.value) + ", capacity " + dec(e.limit) + ")";
    case ErrorCode::kBadCount:
      if (reason == "entries")
        return field + " is " + dec(e.value) + ": allowed 0.." + dec(e.limit);
      if (!reason.empty()) {  // bytes<N>
        return field + ": " + reason + " (length " + dec(e.value) + ", capacity " + dec(e.limit) +
               ")";
      }
      return field + " is " + dec(e.value) + ": allowed " + dec(kMinPlanePoints) + ".." +
             dec(kMaxPlanePoints);
    case ErrorCode::kInternal:  // the decoder could not get its buffer for a split frame
      return field + ": " + reason + ": closing the connection";
    default:
      return field + ": " + std::string(to_string(e.code));
  }
}

}  // namespace

std::string describe(const DecodeError& e) {
  std::string text = sentence(e);
  if (text.size() > 255) text.resize(255);  // as it always was: at most 255 bytes
  return text;
}

}  // namespace ajar::protocol
