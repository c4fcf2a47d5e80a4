// The state file: a versioned header with the clean-shutdown mark and the latched fault, then the
// accepted requests as protocol frames (format 3); the text formats 1 and 2 older ajard wrote,
// still read; replaced atomically; the writer thread, whose stop is bounded when the disk hangs.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/state_store.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajard_restarts.hpp"
#include "fake_door.hpp"
#include "state_file_checksum.hpp"

namespace ajar::daemon {
namespace {

using namespace ajar::testing;

StateRecord full_record() {
  StateRecord state;
  state.clean_shutdown = true;
  ProcedureRecord& r = state.procedure;
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
  return state;
}

StateRecord with(const ProcedureRecord& procedure) {
  return StateRecord{procedure, false};
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

void expect_full(const StateRecord& decoded_state) {
  const ProcedureRecord& r = full_record().procedure;
  const ProcedureRecord* decoded = &decoded_state.procedure;
  ASSERT_TRUE(decoded->width && decoded->handle && decoded->plane && decoded->contact);
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

TEST(StateFormat, RoundTripsBitIdentically) {
  auto decoded_state = decode_state(encode_state(full_record()));
  ASSERT_TRUE(decoded_state.ok()) << decoded_state.error().message;
  EXPECT_TRUE(decoded_state->clean_shutdown);
  EXPECT_EQ(decoded_state->format_version, 3);
  expect_full(*decoded_state);
}

// The requests are stored as protocol frames: the header, then exactly the frames the wire format
// makes of them (request id 0), in the order width, handle, plane, contact.
TEST(StateFormat, StoresTheAcceptedRequestsAsProtocolFrames) {
  const StateRecord state = full_record();
  const std::string bytes = encode_state(state);
  ASSERT_EQ(bytes.compare(0, 8, "AJARSTAT"), 0);
  EXPECT_EQ(static_cast<unsigned char>(bytes[8]), 3);  // format version, little-endian
  EXPECT_EQ(static_cast<unsigned char>(bytes[9]), 0);
  EXPECT_EQ(static_cast<unsigned char>(bytes[16]), 4);  // four frames
  std::vector<std::uint8_t> frames;
  const ProcedureRecord& r = state.procedure;
  for (const protocol::Message& m :
       std::vector<protocol::Message>{*r.width, *r.handle, *r.plane, *r.contact}) {
    ASSERT_TRUE(protocol::encode_append(protocol::Envelope{0, 0, m}, frames));
  }
  ASSERT_EQ(bytes.size(), 22 + frames.size());
  EXPECT_EQ(bytes.substr(22), std::string(frames.begin(), frames.end()));
}

TEST(StateFormat, EmptyRecordRoundTripsAndSaysRunning) {
  auto decoded = decode_state(encode_state(StateRecord{}));
  ASSERT_TRUE(decoded.ok());
  const ProcedureRecord& r = decoded->procedure;
  EXPECT_FALSE(r.width || r.handle || r.plane || r.contact);
  EXPECT_EQ(r.phase, Phase::kIdle);
  EXPECT_FALSE(decoded->clean_shutdown);
  EXPECT_EQ(encode_state(StateRecord{}).size(), 22U);  // the header alone
}

// What older ajard wrote is read (once: the engine's first save rewrites it in format 3): format 2
// with its clean-shutdown mark, format 1 without one, so it reads as not clean (the engine latches
// UNCLEAN_SHUTDOWN); a mark in a format 1 file is refused.
TEST(StateFormat, ReadsTheTextFormatsOneAndTwo) {
  auto v2 = decode_state(legacy_text(full_record(), 2));
  ASSERT_TRUE(v2.ok()) << v2.error().message;
  EXPECT_EQ(v2->format_version, 2);
  EXPECT_TRUE(v2->clean_shutdown);
  expect_full(*v2);

  std::string body = legacy_text(full_record(), 2);
  body = body.substr(0, body.rfind("crc32 "));
  body.replace(0, 12, "ajar-state 1");
  auto with_mark = decode_state(with_checksum(body));
  ASSERT_FALSE(with_mark.ok());  // version 1 never had the line
  EXPECT_NE(with_mark.error().message.find("unexpected"), std::string::npos);
  auto v1 = decode_state(legacy_text(full_record(), 1));
  ASSERT_TRUE(v1.ok()) << v1.error().message;
  EXPECT_EQ(v1->format_version, 1);
  EXPECT_FALSE(v1->clean_shutdown);
  expect_full(*v1);
}

TEST(StateFormat, RefusesCorruptTruncatedAndForeignFiles) {
  const std::string good = encode_state(full_record());
  std::string in_a_frame = good;
  in_a_frame[good.size() - 3] ^= 0x01;  // the contact point: the frame's CRC-32C
  auto refused = decode_state(in_a_frame);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("frame 4"), std::string::npos) << refused.error().message;
  std::string in_the_header = good;
  in_the_header[14] ^= 0x01;  // the fault
  refused = decode_state(in_the_header);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("header checksum"), std::string::npos)
      << refused.error().message;
  for (std::size_t size :
       {std::size_t{0}, std::size_t{10}, std::size_t{21}, good.size() / 2, good.size() - 1}) {
    EXPECT_FALSE(decode_state(good.substr(0, size)).ok()) << size;
  }
  EXPECT_FALSE(decode_state(std::string("\x00\xff garbage", 10)).ok());
  std::string text_flipped = legacy_text(full_record(), 2);
  text_flipped[text_flipped.find("width") + 7] ^= 0x01;
  EXPECT_FALSE(decode_state(text_flipped).ok());

  // A future version with a valid checksum is refused by version, not by checksum.
  std::string v4 = encode_state(StateRecord{});
  v4[8] = 4;
  refused = decode_state(with_header_crc(v4));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "state_file");
  EXPECT_NE(refused.error().message.find("version 4"), std::string::npos)
      << refused.error().message;
}

// A good file with header byte `at` set to `value`, its header signed again: checksum-valid
// nonsense.
std::string header_edited(std::size_t at, std::uint8_t value) {
  std::string bytes = encode_state(full_record());
  bytes[at] = static_cast<char>(value);
  return with_header_crc(bytes);
}

std::string frame_of(const protocol::Message& m) {
  std::vector<std::uint8_t> frame;
  EXPECT_TRUE(protocol::encode_append(protocol::Envelope{0, 0, m}, frame));
  return {frame.begin(), frame.end()};
}

TEST(StateFormat, RefusesImpossibleContentWithAValidChecksum) {
  ASSERT_TRUE(decode_state(header_edited(10, 1)).ok());  // the editor itself is fine
  const struct {
    std::string bytes;
    const char* says;
  } cases[] = {
      {header_edited(14, 0xFF), "fault code '"},  // 0x..FF: not a code
      {header_edited(15, 0xFF), "fault code '"},
      {with_header_crc(header_edited(14, 0x31).replace(15, 1, 1, '\x01')),
       "fault code '305'"},  // 0x0131: a validation code is never latched
      {header_edited(11, 4), "unknown phase 4"},
      {header_edited(12, 2), "aligned is 2"},
      {header_edited(10, 2), "clean_shutdown is 2"},
      {header_edited(13, 7), "plane_consumed is 7"},
      {header_edited(16, 5), "frame count 5"},
      {header_edited(16, 3), "after the last frame"},
      {header_edited(17, 1), "reserved"},
      {encode_state(full_record()) + "x", "1 bytes after the last frame"},
  };
  for (const auto& c : cases) {
    const auto r = decode_state(c.bytes);
    ASSERT_FALSE(r.ok()) << c.says;
    EXPECT_EQ(r.error().field, "state_file");
    EXPECT_NE(r.error().message.find(c.says), std::string::npos)
        << c.says << ": " << r.error().message;
  }
  // Frames the protocol's decoder accepts, but not as a state: a Ping, the width twice, a NaN.
  std::string header = encode_state(StateRecord{});
  header[16] = 2;
  header = with_header_crc(header);
  const auto width = *full_record().procedure.width;
  auto nan_width = width;
  nan_width.p1_hinge.position_m.y() = std::numeric_limits<double>::quiet_NaN();
  const struct {
    std::string frames;
    const char* says;
  } frame_cases[] = {
      {frame_of(width) + frame_of(protocol::Ping{7}), "frame 2: Ping is not a measurement"},
      {frame_of(width) + frame_of(width), "frame 2: MeasureDoorWidth appears twice"},
      {frame_of(nan_width) + frame_of(width), "frame 1: "},
  };
  for (const auto& c : frame_cases) {
    const auto r = decode_state(header + c.frames);
    ASSERT_FALSE(r.ok()) << c.says;
    EXPECT_NE(r.error().message.find(c.says), std::string::npos)
        << c.says << ": " << r.error().message;
  }
}

// The body of an older ajard's good file with `from` replaced by `to`, signed again.
std::string text_edited(const std::string& from, const std::string& to) {
  std::string body = legacy_text(full_record(), 2);
  body = body.substr(0, body.rfind("crc32 "));
  const auto at = body.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: no '" << from << "' in\n" << body;
  if (at != std::string::npos) body.replace(at, from.size(), to);
  return with_checksum(body);
}

TEST(StateFormat, RefusesImpossibleContentInTheTextFormats) {
  ASSERT_TRUE(decode_state(text_edited("fault 512", "fault 512")).ok());  // the editor is fine
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
      {"clean_shutdown 1\n", "", "'clean_shutdown' missing"},
      {"clean_shutdown 1", "clean_shutdown yes", "unexpected"},
      {"ajar-state 2", "ajar-state 3", "version 3"},
  };
  for (const auto& c : cases) {
    const auto r = decode_state(text_edited(c.from, c.to));
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
  StateRecord r;
  std::uint64_t last = 0;
  for (int i = 0; i < 20; ++i) {  // faster than the disk: most of these are never written
    r.procedure.plane_consumed = i % 2 == 0;
    r.procedure.fault = i == 19 ? ErrorCode::kDeadman : ErrorCode::kOk;
    r.clean_shutdown = i == 19;
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
  store.submit(StateRecord{});
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
  ProcedureRecord second_procedure;
  second_procedure.width = good_width();
  const StateRecord second = with(second_procedure);
  ASSERT_TRUE(store.save(second).ok());
  EXPECT_FALSE(std::filesystem::exists(store.path() + ".tmp"));
  auto loaded = store.load();
  ASSERT_TRUE(loaded.ok());
  ASSERT_TRUE(loaded->found);
  EXPECT_TRUE(loaded->record.procedure.width.has_value());
  EXPECT_FALSE(loaded->record.procedure.handle.has_value());
  EXPECT_FALSE(loaded->record.clean_shutdown);
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

// A save that never ends (the temporary file is a FIFO nobody reads: open() blocks, as on a hung
// disk): flush() and stop() give up at their limits instead of waiting for ever, and the store can
// be destroyed under its abandoned writer.
TEST(StateStore, StopIsBoundedWhenTheDiskHangs) {
  TempDir tmp;
  const std::string tmp_file = tmp.path() + "/ajard.state.tmp";
  {
    StateStore store(tmp.path());
    store.prepare();
    store.start();
    ASSERT_EQ(::mkfifo(tmp_file.c_str(), 0600), 0);
    store.submit(full_record());
    EXPECT_FALSE(store.flush(std::chrono::milliseconds(50)));
    EXPECT_FALSE(store.stop(std::chrono::milliseconds(50)));
    EXPECT_EQ(store.settled(), 0U);
    EXPECT_TRUE(store.stop());  // idempotent: nothing left to stop
  }
  // Let the abandoned writer go: a reader on the FIFO ends its open(); it finishes its save.
  std::ifstream reader(tmp_file);
  std::string ignored;
  std::getline(reader, ignored);
  SUCCEED();
}

// The tests' hung disk (ajard_restarts.hpp) made while a save is in flight (its .tmp written, not
// yet renamed: a slow disk holds it there): that save still lands as the state file, and the next
// one hangs. Removing the in-flight .tmp for the FIFO made the writer rename the FIFO over the
// state file (or, one open later, made mkfifo fail: the crash campaign's rare failure).
TEST(StateStore, TheTestsHungDiskLetsASaveInFlightLandAndHangsTheNext) {
  TempDir tmp;
  const std::string tmp_file = tmp.path() + "/ajard.state.tmp";
  {
    StateStore store(tmp.path(), StateStore::Options{std::chrono::milliseconds(300)});
    store.prepare();
    store.start();
    store.submit(full_record());
    for (int i = 0; i < 20000 && !std::filesystem::exists(tmp_file); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ASSERT_TRUE(std::filesystem::is_regular_file(tmp_file)) << "the writer never began its save";
    ASSERT_TRUE(test::hang_disk(tmp.path()));
    ASSERT_TRUE(store.flush(std::chrono::seconds(20)));
    ASSERT_TRUE(std::filesystem::is_regular_file(store.path())) << "the FIFO became the state file";
    EXPECT_EQ(read_all(store.path()), encode_state(full_record()));
    EXPECT_TRUE(std::filesystem::is_fifo(tmp_file));
    store.submit(StateRecord{});
    EXPECT_FALSE(store.flush(std::chrono::milliseconds(50)));
    EXPECT_EQ(store.settled(), 1U);
    EXPECT_FALSE(store.stop(std::chrono::milliseconds(50)));
  }
  // Let the abandoned writer go (as in StopIsBoundedWhenTheDiskHangs).
  std::ifstream reader(tmp_file);
  std::string ignored;
  std::getline(reader, ignored);
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
