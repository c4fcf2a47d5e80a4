// The state file: versioned text with a checksum, replaced atomically.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/state_store.hpp"
#include "fake_door.hpp"
#include "state_file_checksum.hpp"

namespace ajar::daemon {
namespace {

using namespace ajar::testing;

ProcedureRecord full_record() {
  ProcedureRecord r;
  auto width = good_width();
  width.p1_hinge.position_m.x() = 0.1 + 0.2;  // not exactly representable in short decimal
  width.p2_moving_edge.position_m.z() = 1e-300;
  r.width = width;
  r.handle = good_handle();
  r.plane = plane_at_yaw(0.123456789);
  r.plane->points[1].frame = core::Frame::kCamera;
  r.contact = good_contact();
  r.aligned = true;
  r.plane_consumed = false;
  r.phase = Phase::kEngaged;
  r.fault = ErrorCode::kDeadman;
  return r;
}

void expect_same(const core::FramedPoint& a, const core::FramedPoint& b) {
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.position_m.x(), b.position_m.x());  // bit-identical, not approximately
  EXPECT_EQ(a.position_m.y(), b.position_m.y());
  EXPECT_EQ(a.position_m.z(), b.position_m.z());
}

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(StateFormat, RoundTripsBitIdentically) {
  const ProcedureRecord r = full_record();
  auto decoded = decode_state(encode_state(r));
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  expect_same(decoded->width->p1_hinge, r.width->p1_hinge);
  expect_same(decoded->width->p2_moving_edge, r.width->p2_moving_edge);
  expect_same(decoded->handle->p2_free_end, r.handle->p2_free_end);
  ASSERT_EQ(decoded->plane->count, 3);
  for (std::size_t i = 0; i < 3; ++i)
    expect_same(decoded->plane->points[i], r.plane->points[i]);
  expect_same(decoded->contact->contact, r.contact->contact);
  EXPECT_TRUE(decoded->aligned);
  EXPECT_FALSE(decoded->plane_consumed);
  EXPECT_EQ(decoded->phase, Phase::kEngaged);
  EXPECT_EQ(decoded->fault, ErrorCode::kDeadman);
}

TEST(StateFormat, EmptyRecordRoundTrips) {
  auto decoded = decode_state(encode_state(ProcedureRecord{}));
  ASSERT_TRUE(decoded.ok());
  EXPECT_FALSE(decoded->width || decoded->handle || decoded->plane || decoded->contact);
  EXPECT_EQ(decoded->phase, Phase::kIdle);
}

TEST(StateFormat, RefusesCorruptTruncatedAndForeignFiles) {
  const std::string good = encode_state(full_record());
  std::string flipped = good;
  flipped[good.find("width") + 7] ^= 0x01;
  EXPECT_FALSE(decode_state(flipped).ok());
  EXPECT_FALSE(decode_state(good.substr(0, good.size() / 2)).ok());
  EXPECT_FALSE(decode_state("").ok());
  EXPECT_FALSE(decode_state("\x00\xff garbage").ok());

  // A future version with a valid checksum is refused by version, not by checksum.
  std::string v2 = encode_state(ProcedureRecord{});
  v2 = v2.substr(0, v2.rfind("crc32")).replace(0, 12, "ajar-state 2");
  auto refused = decode_state(with_checksum(v2));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "state_file");
  EXPECT_NE(refused.error().message.find("version 2"), std::string::npos)
      << refused.error().message;
}

// The body of a good file with `from` replaced by `to`, signed again: checksum-valid nonsense.
std::string edited(const std::string& from, const std::string& to) {
  std::string body = encode_state(full_record());
  body = body.substr(0, body.rfind("crc32 "));
  const auto at = body.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: no '" << from << "' in\n" << body;
  if (at != std::string::npos) body.replace(at, from.size(), to);
  return with_checksum(body);
}

TEST(StateFormat, RefusesImpossibleContentWithAValidChecksum) {
  ASSERT_TRUE(decode_state(edited("fault 512", "fault 512")).ok());  // the editor itself is fine
  const struct {
    const char* from;
    const char* to;
    const char* says;
  } cases[] = {
      {"fault 512", "fault 65535", "fault code '65535'"},
      {"fault 512", "fault 305", "fault code '305'"},  // a validation code is never latched
      {"fault 512", "fault -1", "fault code"},
      {"phase engaged", "phase flying", "unknown phase"},
      {"aligned 1", "aligned 2", "unexpected"},
      {"width base 0.30000000000000004", "width base nan", "bad width"},
      {"width base 0.30000000000000004", "width base inf", "bad width"},
      {"width base 0.30000000000000004", "width base 1e999", "bad width"},
      {"width base", "width sky", "bad width"},
      {"plane 3", "plane 2", "plane point count"},
      {"plane_consumed 0\n", "plane_consumed 0\nplane_consumed 1\n", "appears twice"},
      {"phase engaged\n", "", "'phase' missing"},
      {"fault 512\n", "", "'fault' missing"},
  };
  for (const auto& c : cases) {
    const auto r = decode_state(edited(c.from, c.to));
    ASSERT_FALSE(r.ok()) << c.to;
    EXPECT_EQ(r.error().field, "state_file");
    EXPECT_NE(r.error().message.find(c.says), std::string::npos)
        << c.to << ": " << r.error().message;
  }
}

TEST(StateStore, AFailedSaveLeavesNoTemporaryFile) {
  TempDir tmp;
  StateStore store(tmp.path());
  store.prepare();
  // The target is a non-empty directory: the rename fails after the .tmp was written.
  std::filesystem::create_directories(store.path() + "/occupied");
  const auto saved = store.save(full_record());
  ASSERT_FALSE(saved.ok());
  EXPECT_NE(saved.error().message.find("rename"), std::string::npos) << saved.error().message;
  EXPECT_FALSE(std::filesystem::exists(store.path() + ".tmp"));
}

TEST(StateStore, TheWriterThreadCoalescesAndSettlesEveryGeneration) {
  TempDir tmp;
  StateStore store(tmp.path(), StateStore::Options{std::chrono::milliseconds(50)});
  store.prepare();
  store.start();
  ProcedureRecord r;
  std::uint64_t last = 0;
  for (int i = 0; i < 20; ++i) {  // faster than the disk: most of these are never written
    r.plane_consumed = i % 2 == 0;
    r.fault = i == 19 ? ErrorCode::kDeadman : ErrorCode::kOk;
    last = store.submit(r);
  }
  EXPECT_EQ(last, 20U);
  EXPECT_EQ(store.submitted(), 20U);
  ASSERT_TRUE(store.flush(std::chrono::seconds(20)));
  EXPECT_EQ(store.settled(), 20U);
  EXPECT_TRUE(store.take_errors().empty());
  EXPECT_EQ(read_all(store.path()), encode_state(r));  // the latest record won
  store.stop();
}

TEST(StateStore, WriterFailuresAreReportedOnce) {
  TempDir tmp;
  StateStore store(tmp.path());
  store.prepare();
  store.start();
  std::filesystem::create_directories(store.path() + "/occupied");
  store.submit(full_record());
  ASSERT_TRUE(store.flush(std::chrono::seconds(20)));
  store.submit(full_record());
  ASSERT_TRUE(store.flush(std::chrono::seconds(20)));
  EXPECT_EQ(store.take_errors().size(), 1U);  // the same failure twice: reported once
  std::filesystem::remove_all(store.path());
  store.submit(ProcedureRecord{});
  ASSERT_TRUE(store.flush(std::chrono::seconds(20)));
  EXPECT_TRUE(store.take_errors().empty());
  EXPECT_EQ(store.settled(), 3U);
}

TEST(StateStore, SavesAtomicallyAndLoads) {
  TempDir tmp;
  StateStore store(tmp.path() + "/nested/state");
  store.prepare();
  auto missing = store.load();
  ASSERT_TRUE(missing.ok());
  EXPECT_FALSE(missing->found);

  ASSERT_TRUE(store.save(full_record()).ok());
  ProcedureRecord second;
  second.width = good_width();
  ASSERT_TRUE(store.save(second).ok());
  EXPECT_FALSE(std::filesystem::exists(store.path() + ".tmp"));
  auto loaded = store.load();
  ASSERT_TRUE(loaded.ok());
  ASSERT_TRUE(loaded->found);
  EXPECT_TRUE(loaded->record.width.has_value());
  EXPECT_FALSE(loaded->record.handle.has_value());
  EXPECT_EQ(read_all(store.path()), encode_state(second));
}

TEST(StateStore, CorruptFileIsReportedNotThrown) {
  TempDir tmp;
  StateStore store(tmp.path());
  store.prepare();
  std::ofstream(store.path()) << "ajar-state 1\nwidth nonsense\n";
  auto loaded = store.load();
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.error().message.find(store.path()), std::string::npos);
}

TEST(StateStore, UncreatableDirectoryIsAStartupError) {
  TempDir tmp;
  const std::string file = tmp.path() + "/a-file";
  std::ofstream(file) << "x";
  StateStore store(file + "/state");
  EXPECT_THROW(store.prepare(), StartupError);
}

}  // namespace
}  // namespace ajar::daemon
