// Golden vectors (tests/conformance/vectors/*.vec): every one is checked with check_vector(); the
// set must cover every message type, every Ack body and every decoder error.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/vectors.hpp"
#include "samples.hpp"

namespace ajar::protocol {
namespace {

std::vector<std::pair<std::string, GoldenVector>> load_all() {
  std::vector<std::pair<std::string, GoldenVector>> out;
  for (const auto& entry : std::filesystem::directory_iterator(AJAR_VECTOR_DIR)) {
    if (entry.path().extension() != ".vec") continue;
    std::ifstream f(entry.path(), std::ios::binary);
    std::stringstream text;
    text << f.rdbuf();
    auto v = parse_vector(text.str());
    EXPECT_TRUE(v.ok()) << entry.path() << ": " << (v.ok() ? "" : v.error().message);
    if (v.ok()) out.emplace_back(entry.path().filename().string(), std::move(v).value());
  }
  return out;
}

TEST(Vectors, EveryVectorPasses) {
  const auto all = load_all();
  ASSERT_GE(all.size(), 40u);
  for (const auto& [file, v] : all) {
    EXPECT_EQ(file, v.name + ".vec");
    const auto result = check_vector(v);
    EXPECT_TRUE(result.ok()) << file << ": " << (result.ok() ? "" : result.error().message);
  }
}

// The committed valid vectors are exactly what the generator makes of the samples today: the Ack
// vectors' derived values are what core computes from their requests (self-consistent worked
// examples), and nobody edits a vector by hand. Regenerate with ajar_protocol_vector_gen.
TEST(Vectors, CommittedVectorsAreWhatTheCodeGenerates) {
  const auto all = load_all();
  std::size_t compared = 0;
  for (const auto& sample : samples::all()) {
    for (const auto& [file, v] : all) {
      if (v.name != sample.name) continue;
      std::vector<std::uint8_t> bytes;
      ASSERT_TRUE(
          encode_append(sample.envelope, bytes, samples::vector_minor(sample.envelope.message)))
          << sample.name;
      EXPECT_EQ(bytes, v.bytes) << file << " differs from what the code generates: run "
                                << "ajar_protocol_vector_gen tests/conformance/vectors";
      ++compared;
    }
  }
  EXPECT_EQ(compared, samples::all().size()) << "a sample has no committed vector";
}

// The Ack vectors are the daemon's answers to the request vectors: recompute them through core.
TEST(Vectors, AckVectorsFollowFromTheirRequests) {
  const auto width = samples::width_ack();
  const auto r = samples::width_request();
  const core::Vec3 p1 = samples::sample_transform().to_base(r.p1_hinge);
  const core::Vec3 p2 = samples::sample_transform().to_base(r.p2_moving_edge);
  EXPECT_DOUBLE_EQ(width.length_m, (p2 - p1).norm());
  EXPECT_EQ(width.direction, p1.y() > p2.y() ? core::RotationDirection::kCounterClockwise
                                             : core::RotationDirection::kClockwise);
  const auto plane = samples::plane_ack();
  EXPECT_NEAR(plane.normal.norm(), 1.0, 1e-12);
  EXPECT_NEAR(plane.yaw_deviation_rad, std::atan2(-plane.normal.y(), -plane.normal.x()), 1e-12);
  const auto base = samples::sample_base();
  EXPECT_NEAR(plane.right_wheel_rad,
              plane.yaw_deviation_rad * base.turning_radius_m / base.wheel_radius_m, 1e-12);
  EXPECT_EQ(plane.left_counts, -plane.right_counts * base.left.polarity * base.right.polarity);
}

TEST(Vectors, CoverEveryTypeAckBodyAndError) {
  std::set<MessageType> types;
  std::set<MessageType> acked;
  std::set<ErrorCode> errors;
  for (const auto& [file, v] : load_all()) {
    if (v.expect_ok) {
      const auto out = decode_frame(v.bytes);
      ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << file;
      types.insert(type_of(out.envelope.message));
      if (const auto* ack = std::get_if<Ack>(&out.envelope.message))
        acked.insert(ack->acknowledged);
    } else {
      errors.insert(v.expected_error);
    }
  }
  EXPECT_EQ(types.size(), std::variant_size_v<Message>);
  for (auto t :
       {MessageType::kMeasureDoorWidth, MessageType::kMeasureHandle, MessageType::kMeasureDoorPlane,
        MessageType::kSetContactPoint, MessageType::kAlignBase}) {
    EXPECT_TRUE(acked.count(t)) << to_string(t);
  }
  for (ErrorCode c = ErrorCode::kBadMagic; c <= ErrorCode::kBadCount;
       c = static_cast<ErrorCode>(static_cast<int>(c) + 1)) {
    EXPECT_TRUE(errors.count(c)) << "no vector produces " << to_string(c);
  }
}

TEST(Vectors, ParserRoundTripsAndRejectsGarbage) {
  GoldenVector v;
  v.name = "x";
  v.direction = GoldenVector::Direction::kDaemonToHost;
  v.expect_ok = false;
  v.expected_error = ErrorCode::kBadMagic;
  v.framing_lost = true;
  v.field = "header.magic";
  v.bytes = {0x00, 0xff, 0x10};
  auto parsed = parse_vector(format_vector(v, "two\nlines"));
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(parsed->name, "x");
  EXPECT_EQ(parsed->direction, GoldenVector::Direction::kDaemonToHost);
  EXPECT_FALSE(parsed->expect_ok);
  EXPECT_EQ(parsed->expected_error, ErrorCode::kBadMagic);
  EXPECT_TRUE(parsed->framing_lost);
  EXPECT_EQ(parsed->field, "header.magic");
  EXPECT_EQ(parsed->bytes, v.bytes);

  const auto ok =
      parse_vector("name: a\ndirection: host_to_daemon\nexpect: ok\nfuture: x\nhex: 0a\n");
  ASSERT_TRUE(ok.ok());
  EXPECT_TRUE(ok->roundtrip);
  EXPECT_EQ(ok->bytes, std::vector<std::uint8_t>{0x0a});

  EXPECT_FALSE(parse_vector("direction: host_to_daemon\nexpect: ok\nhex: 00\n").ok());
  EXPECT_FALSE(parse_vector("name: a\ndirection: sideways\nexpect: ok\nhex: 00\n").ok());
  EXPECT_FALSE(
      parse_vector("name: a\ndirection: host_to_daemon\nexpect: error NOPE\nhex: 00\n").ok());
  EXPECT_FALSE(parse_vector("name: a\ndirection: host_to_daemon\nexpect: ok\nhex: 0g\n").ok());
  EXPECT_FALSE(parse_vector("name: a\ndirection: host_to_daemon\nexpect: ok\nhex: 012\n").ok());
  EXPECT_FALSE(parse_vector("name: a\ndirection: host_to_daemon\nexpect: ok\n").ok());
  EXPECT_FALSE(parse_vector("name a\n").ok());
  EXPECT_EQ(error_code_from_string("CRC_MISMATCH"), ErrorCode::kCrcMismatch);
  EXPECT_EQ(error_code_from_string("UNKNOWN"), std::nullopt);
}

TEST(Vectors, CheckVectorCatchesAWrongExpectation) {
  GoldenVector v;
  v.name = "ping";
  ASSERT_TRUE(encode_append(Envelope{1, 0, Ping{5}}, v.bytes));
  EXPECT_TRUE(check_vector(v).ok());
  v.direction = GoldenVector::Direction::kDaemonToHost;
  EXPECT_FALSE(check_vector(v).ok());
  v.direction = GoldenVector::Direction::kHostToDaemon;
  v.expect_ok = false;
  v.expected_error = ErrorCode::kCrcMismatch;
  EXPECT_FALSE(check_vector(v).ok());
  v.bytes[kHeaderSize + 3] ^= 1;
  EXPECT_TRUE(check_vector(v).ok());
  v.field = "header.flags";
  EXPECT_FALSE(check_vector(v).ok());
}

}  // namespace
}  // namespace ajar::protocol
