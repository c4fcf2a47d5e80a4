// Decode errors built on purpose (independent of the vector files).
#include "suite.hpp"

namespace ajar::conformance {
namespace {

std::vector<std::uint8_t> ping_frame(std::uint32_t id) {
  return frame_bytes(protocol::Envelope{id, 0, protocol::Ping{7}});
}

}  // namespace

// ---- decode errors built here (independent of the vector files) ----
void Suite::decode_errors() {
  decode_header_errors();
  decode_payload_errors();
  decode_framing();
}

// Header errors that skip the one frame: refused, not executed, the session goes on.
void Suite::decode_header_errors() {
  check("decode: CRC_MISMATCH is refused, not executed, session continues", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9001);
    f.back() ^= 0x01;
    if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kCrcMismatch, "header.crc");
        !e.empty()) {
      return e;
    }
    return still_usable(*c);
  });
  check("decode: UNKNOWN_MESSAGE_TYPE (0x01ff) keeps the session usable", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9002);
    put_u16(f, protocol::kOffsetType, 0x01ff);
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, 9002), ErrorCode::kUnknownMessageType, nullptr, 9002);
        !e.empty()) {
      return e;
    }
    return still_usable(*c);
  });
  check("decode: a daemon-to-host type sent to the daemon is UNKNOWN_MESSAGE_TYPE", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    const auto f = frame_bytes(protocol::Envelope{9003, 0, protocol::Pong{1, 2}});
    if (auto e = want_error(raw(*c, f, 9003), ErrorCode::kUnknownMessageType); !e.empty()) return e;
    return still_usable(*c);
  });
  check("decode: UNKNOWN_FLAGS refuses the frame (not executed)", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9004);
    put_u16(f, protocol::kOffsetFlags, 0x0004);
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, 9004), ErrorCode::kUnknownFlags, "header.flags", 9004);
        !e.empty()) {
      return e;
    }
    return still_usable(*c);
  });
}

// Payload errors that skip the one frame: refused, not executed, the session goes on.
void Suite::decode_payload_errors() {
  check("decode: BAD_PAYLOAD_LENGTH (Ping with 7 bytes)", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9005);
    f.pop_back();
    put_u32(f, protocol::kOffsetPayloadLength, 7);
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, 9005), ErrorCode::kBadPayloadLength, nullptr, 9005);
        !e.empty()) {
      return e;
    }
    return still_usable(*c);
  });
  check("decode: NON_FINITE_NUMBER (NaN in p2.z), nothing executed", [&] {
    auto c = greeted(Role::kController, true);
    if (!c) return std::string("cannot connect");
    protocol::MeasureDoorWidth m{base_point(1, 0.4, 0), base_point(1, -0.4, 0)};
    auto f = frame_bytes(protocol::Envelope{c->next_request_id(), 0, m});
    // p2.z is the last 8 payload bytes: a quiet NaN.
    const std::uint64_t nan_bits = 0x7ff8000000000000ull;
    for (std::size_t i = 0; i < 8; ++i) {
      f[f.size() - 8 + i] = static_cast<std::uint8_t>(nan_bits >> (8 * i));
    }
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kNonFiniteNumber, "p2.z");
        !e.empty()) {
      return e;
    }
    const auto s = status(*c);
    if (!s || s->has_width) return std::string("a width was stored");
    return std::string{};
  });
  check("decode: INVALID_ENUM_VALUE (points[1].frame = 7)", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = frame_bytes(protocol::Envelope{9007, 0, door_plane(0.1)});
    f[protocol::kHeaderSize + 1 + 25] = 7;
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, 9007), ErrorCode::kInvalidEnumValue, "points[1].frame");
        !e.empty()) {
      return e;
    }
    return still_usable(*c);
  });
  check("decode: BAD_COUNT (plane with count 2)", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = frame_bytes(protocol::Envelope{9008, 0, door_plane(0.1)});
    f[protocol::kHeaderSize] = 2;
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, 9008), ErrorCode::kBadCount, "count"); !e.empty()) return e;
    return still_usable(*c);
  });
  check("decode: BAD_STRING (control character in client_name)", [&] {
    auto c = open();
    if (!c) return std::string("cannot connect");
    protocol::Hello hello;
    hello.client_name = "abc";
    auto f = frame_bytes(protocol::Envelope{9009, 0, hello});
    f[protocol::kHeaderSize + 12 + 2] = 0x07;
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, 9009), ErrorCode::kBadString, "client_name"); !e.empty()) {
      return e;
    }
    // The refused Hello did not greet the session.
    if (auto e = want_error(c->request(protocol::GetStatus{}), ErrorCode::kHelloRequired);
        !e.empty()) {
      return e;
    }
    return std::string{};
  });
}

// Errors that lose the framing (the connection closes), and frames in any chunking.
void Suite::decode_framing() {
  check("decode: UNSUPPORTED_VERSION in the header closes the connection", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9010);
    f[protocol::kOffsetVersionMajor] = 2;
    fix_crc(f);
    if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kUnsupportedVersion); !e.empty()) {
      return e;
    }
    return c->wait_closed(timeout()) ? std::string{} : std::string("connection not closed");
  });
  check("decode: PAYLOAD_TOO_LARGE closes the connection", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9011);
    put_u32(f, protocol::kOffsetPayloadLength, 1025);
    if (auto e = want_error(raw(*c, f, std::nullopt), ErrorCode::kPayloadTooLarge); !e.empty()) {
      return e;
    }
    return c->wait_closed(timeout()) ? std::string{} : std::string("connection not closed");
  });
  check("decode: BAD_MAGIC closes the connection", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    const std::vector<std::uint8_t> junk{'G', 'E', 'T', ' ', '/', ' ', 'H', 'T', 'T', 'P'};
    if (auto e = want_error(raw(*c, junk, std::nullopt), ErrorCode::kBadMagic, "header.magic");
        !e.empty()) {
      return e;
    }
    return c->wait_closed(timeout()) ? std::string{} : std::string("connection not closed");
  });
  check("decode: a frame split into single bytes is decoded", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    const auto f = ping_frame(9012);
    for (std::uint8_t b : f)
      c->send_raw(std::span<const std::uint8_t>(&b, 1));
    auto reply = c->wait_reply(9012, timeout());
    if (!reply || !std::holds_alternative<protocol::Pong>(reply->message)) {
      return "got " + describe(reply);
    }
    return std::string{};
  });
  check("decode: two frames in one write are both answered, in order", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    auto f = ping_frame(9013);
    const auto g = frame_bytes(protocol::Envelope{9014, 0, protocol::GetStatus{}});
    f.insert(f.end(), g.begin(), g.end());
    c->send_raw(f);
    auto first = c->wait_reply(std::nullopt, timeout());
    auto second = c->wait_reply(std::nullopt, timeout());
    if (!first || first->request_id != 9013 || !second || second->request_id != 9014) {
      return std::string("replies missing or out of order");
    }
    return std::string{};
  });
}

}  // namespace ajar::conformance
