// The recorder (recorder.hpp) end to end on a real directory: what goes in comes out (per channel,
// in order, as the counters say), files are 0640, rotation keeps the budget and never removes a
// saved recording, a slow disk and a full disk (a small tmpfs, when root) lose only what they
// count, and read() serves the bytes by offset.
#include "ajar/recorder/recorder.hpp"

#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <future>
#include <mutex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "ajar/recorder/channels.hpp"
#include "eventually.hpp"
#include "mcap_read.hpp"

namespace ajar::recorder {
namespace {
namespace fs = std::filesystem;
using ajar::test::eventually;

struct TempDir {
  fs::path path;
  TempDir() {
    char tmpl[] = "/tmp/ajar-recorder-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

LoopSample sample(std::uint64_t cycle) {
  LoopSample s;
  s.cycle = cycle;
  s.time_ns = static_cast<std::int64_t>(1'000'000'000 + cycle * 2'000'000);
  s.measured_rad[0] = 0.001 * static_cast<double>(cycle);
  return s;
}

// What the control loop does each cycle: the sample only when the decimation takes it.
void offer(Recorder& r, const LoopSample& s) {
  if (r.take_loop_sample()) r.loop_sample(s);
}

struct Logged {
  std::mutex m;
  std::vector<std::string> lines;
  Recorder::Log sink() {
    return [this](std::string_view line) {
      std::lock_guard lock(m);
      lines.emplace_back(line);
    };
  }
  std::size_t size() {
    std::lock_guard lock(m);
    return lines.size();
  }
};

std::vector<fs::path> recordings(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".mcap") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Recorder, WhatGoesInComesOutPerChannelAndTheFileIs0640) {
  TempDir dir;
  RecorderSettings settings;
  settings.directory = (dir.path / "rec").string();
  settings.loop_decimation = 3;
  settings.monotonic_origin_ns = 1'000'000'000;
  Logged log;
  Recorder r(settings, log.sink());
  r.start();
  for (std::uint64_t i = 1; i <= 300; ++i)
    offer(r, sample(i));  // every 3rd: 100
  const std::uint8_t frame[] = {0xA5, 1, 2, 3};
  for (std::uint64_t i = 0; i < 40; ++i)
    r.frame(kWireIn, 7, 1000 + i, frame);
  // A frame sent to many sessions: its bytes shared, recorded once per session all the same.
  const auto shared =
      std::make_shared<const std::vector<std::uint8_t>>(std::begin(frame), std::end(frame));
  for (std::uint64_t i = 0; i < 10; ++i)
    r.frame(kWireOut, 100 + i, 1040 + i, shared);
  for (std::uint64_t i = 0; i < 5; ++i) {
    r.json(
        kEventsChannel, 2000 + i,
        R"({"daemon_time_ns":1,"kind":"state_changed","state":"aligned","fault":"OK","detail":)" +
            json_string("line \"one\"\n") + "}");
  }
  ASSERT_TRUE(eventually([&] { return r.counters().messages_written >= 155; }));
  r.stop();
  const auto c = r.counters();
  EXPECT_EQ(c.loop_samples, 100U);
  EXPECT_EQ(c.loop_dropped, 0U);
  EXPECT_EQ(c.io_records, 55U);
  EXPECT_EQ(c.io_dropped, 0U);
  EXPECT_EQ(c.write_failures, 0U);
  EXPECT_EQ(log.size(), 0U);

  const auto files = recordings(settings.directory);
  ASSERT_EQ(files.size(), 1U);
  struct stat st {};
  ASSERT_EQ(::stat(files[0].c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640U);
  ASSERT_EQ(::stat(settings.directory.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0750U);

  const auto f = test::read_mcap(test::file_bytes(files[0]));
  EXPECT_TRUE(f.complete) << "a stopped recorder closes its file with a footer";
  EXPECT_EQ(f.counts.at(kLoopChannel), 100U);
  EXPECT_EQ(f.counts.at(kWireChannel), 50U);
  EXPECT_EQ(f.counts.at(kEventsChannel), 5U);
  EXPECT_GE(f.counts.at(kRecorderChannel), 2U) << "the counters at the file's start and end";
  EXPECT_EQ(c.messages_written, f.messages.size());
  // Loop samples in order, the 3rd, 6th, ... cycle; wire messages carry the layout's header.
  std::uint64_t expect_cycle = 3, wire = 0;
  for (const auto& m : f.messages) {
    if (m.channel == kLoopChannel) {
      const std::string text(m.data.begin(), m.data.end());
      EXPECT_EQ(text.rfind("{\"cycle\":" + std::to_string(expect_cycle) + ",", 0), 0U) << text;
      expect_cycle += 3;
    } else if (m.channel == kWireChannel) {
      ASSERT_EQ(m.data.size(), kWireHeaderBytes + 4);
      EXPECT_EQ(m.data[0], kWireLayoutVersion);
      const std::uint64_t time = test::le(m.data, 10, 8);
      if (wire < 40) {
        EXPECT_EQ(m.data[1], kWireIn);
        EXPECT_EQ(test::le(m.data, 2, 8), 7U);
      } else {
        EXPECT_EQ(m.data[1], kWireOut);
        EXPECT_EQ(test::le(m.data, 2, 8), 100 + wire - 40) << "the session it was sent to";
      }
      EXPECT_EQ(time, 1000 + wire);
      EXPECT_TRUE(
          std::equal(std::begin(frame), std::end(frame), m.data.begin() + kWireHeaderBytes));
      ++wire;
    }
  }
}

TEST(Recorder, RotationKeepsTheBudgetAndNeverRemovesASavedRecording) {
  TempDir dir;
  RecorderSettings settings;
  settings.directory = dir.path.string();
  settings.loop_decimation = 1;
  settings.max_file_bytes = 48 << 10;  // ~20 KiB of schemas, then ~60 samples
  settings.max_bytes = 192 << 10;
  Recorder r(settings, {});
  r.start();
  std::uint64_t cycle = 0;
  // As fast as the recorder writes (a rotation, with its fdatasync, every ~60 samples), at most
  // ~400 samples ahead of what is on disk (messages_written also counts two status messages per
  // file: ~3 %): the ring (kLoopRingCapacity) never fills, so nothing may be dropped.
  const auto feed = [&](int n) {
    for (int i = 0; i < n; ++i) {
      offer(r, sample(++cycle));
      if (i % 100 == 0) {
        ASSERT_TRUE(eventually([&] { return r.counters().messages_written + 400 >= cycle; }));
      }
    }
  };
  feed(2000);
  ASSERT_TRUE(eventually([&] { return r.counters().messages_written >= 2000; }));
  std::promise<SaveResult> saved;
  r.save_last(3600, [&](SaveResult s) { saved.set_value(std::move(s)); });
  const SaveResult s = saved.get_future().get();
  ASSERT_TRUE(s.ok) << s.error;
  ASSERT_FALSE(s.names.empty());
  std::uint64_t saved_bytes = 0;
  for (const auto& name : s.names)
    saved_bytes += fs::file_size(dir.path / name);
  EXPECT_EQ(r.counters().saved_bytes, saved_bytes) << "counted when saved";
  feed(4000);
  ASSERT_TRUE(eventually([&] { return r.counters().messages_written >= 6000; }));
  r.stop();
  EXPECT_EQ(r.counters().loop_dropped, 0U);
  std::uint64_t total = 0;
  const auto files = recordings(dir.path);
  EXPECT_GE(files.size(), 3U) << "rotated by size";
  for (const auto& p : files) {
    total += fs::file_size(p);
    EXPECT_TRUE(test::read_mcap(test::file_bytes(p)).complete) << p;
  }
  // The budget holds after each rotation; the file being written may add up to one file more.
  EXPECT_LE(total, settings.max_bytes + settings.max_file_bytes + (8 << 10));
  for (const auto& name : s.names) {
    EXPECT_TRUE(fs::exists(dir.path / name)) << name << " was removed by rotation";
  }
  const auto listed = r.list();
  std::size_t saved_listed = 0;
  for (const auto& info : listed)
    saved_listed += info.saved ? 1 : 0;
  EXPECT_EQ(saved_listed, s.names.size());
}

TEST(Recorder, ReadServesTheBytesByOffsetAndRefusesOtherNames) {
  TempDir dir;
  RecorderSettings settings;
  settings.directory = dir.path.string();
  Recorder r(settings, {});
  r.start();
  for (std::uint64_t i = 1; i <= 500; ++i)
    offer(r, sample(i));
  r.stop();
  const auto listed = r.list();
  ASSERT_EQ(listed.size(), 1U);
  EXPECT_FALSE(listed[0].active);
  std::vector<std::uint8_t> joined;
  std::string error;
  for (std::uint64_t off = 0;; off += 1000) {
    const auto part = r.read(listed[0].name, off, 1000, &error);
    ASSERT_TRUE(part) << error;
    if (part->empty()) break;
    joined.insert(joined.end(), part->begin(), part->end());
  }
  EXPECT_EQ(joined, test::file_bytes(dir.path / listed[0].name));
  for (const char* bad : {"../etc/passwd", "x.mcap", "saved/../../x", "/etc/passwd",
                          "ajard-20260101T000000000Z.mcap"}) {
    EXPECT_FALSE(r.read(bad, 0, 10, &error)) << bad;
  }
}

TEST(Recorder, ASlowDiskNeverBlocksTheInputsAndLosesOnlyWhatItCounts) {
  TempDir dir;
  RecorderSettings settings;
  settings.directory = dir.path.string();
  settings.loop_decimation = 1;
  settings.write_delay_ms = 200;
  Recorder r(settings, {});
  r.start();
  // Far more than the ring holds while the recorder thread sleeps in write: the inputs return
  // anyway (this thread would hang otherwise) and count the drops.
  for (std::uint64_t i = 1; i <= 3 * Recorder::kLoopRingCapacity; ++i)
    offer(r, sample(i));
  const std::uint8_t frame[] = {1, 2, 3};
  for (int i = 0; i < 100; ++i)
    r.frame(kWireOut, 1, 5, frame);
  const auto c = r.counters();
  EXPECT_EQ(c.loop_samples, 3 * Recorder::kLoopRingCapacity);
  EXPECT_GT(c.loop_dropped, 0U);
  r.stop();
  const auto end = r.counters();
  const auto files = recordings(dir.path);
  ASSERT_EQ(files.size(), 1U);
  const auto f = test::read_mcap(test::file_bytes(files[0]));
  EXPECT_TRUE(f.complete);
  EXPECT_EQ(f.counts.at(kLoopChannel) + end.loop_dropped, end.loop_samples);
  EXPECT_EQ(f.counts.at(kWireChannel) + end.io_dropped, 100U);
}

// A disk that stalls in the first write (the write delay of an hour, cut short by stop()): start()
// returns at once (the recorder thread opens the file), the counters say what happens meanwhile —
// recording, nothing written, the ring full and dropping — and stop() returns at once with the file
// written and closed; then the counters say where every record went and the bytes on disk.
TEST(Recorder, AStalledDiskDelaysNeitherStartNorStopAndTheCountersSayWhereEveryRecordWent) {
  TempDir dir;
  RecorderSettings settings;
  settings.directory = dir.path.string();
  settings.loop_decimation = 1;
  settings.write_delay_ms = 3'600'000;
  Recorder r(settings, {});
  auto started = std::async(std::launch::async, [&] { r.start(); });
  ASSERT_EQ(started.wait_for(std::chrono::seconds(20)), std::future_status::ready)
      << "start() waited for the disk";
  ASSERT_TRUE(eventually([&] { return r.counters().recording; }));
  for (std::uint64_t i = 1; i <= 3 * Recorder::kLoopRingCapacity; ++i)
    offer(r, sample(i));
  const auto c = r.counters();
  EXPECT_EQ(c.mode, RecorderMode::kRecording);
  EXPECT_TRUE(c.file.starts_with("ajard-") && c.file.ends_with(".mcap")) << c.file;
  EXPECT_EQ(c.messages_written, 0U);
  EXPECT_EQ(c.last_write_ns, 0U) << "recording and nothing written yet: a stalled disk";
  EXPECT_EQ(c.loop_samples, 3 * Recorder::kLoopRingCapacity);
  EXPECT_EQ(c.loop_dropped, 2 * Recorder::kLoopRingCapacity) << "the ring holds its capacity";
  EXPECT_GT(c.disk_free_bytes, 0U);
  auto stopped = std::async(std::launch::async, [&] { r.stop(); });
  ASSERT_EQ(stopped.wait_for(std::chrono::seconds(20)), std::future_status::ready)
      << "stop() waited for the disk";
  const auto end = r.counters();
  const auto files = recordings(dir.path);
  ASSERT_EQ(files.size(), 1U);
  const auto f = test::read_mcap(test::file_bytes(files[0]));
  EXPECT_TRUE(f.complete);
  EXPECT_EQ(f.counts.at(kLoopChannel), Recorder::kLoopRingCapacity);
  EXPECT_EQ(end.messages_written, f.messages.size());
  EXPECT_GT(end.last_write_ns, 0U);
  EXPECT_EQ(end.mode, RecorderMode::kOff);
  EXPECT_TRUE(end.file.empty());
  EXPECT_EQ(end.file_bytes, 0U) << "no file open";
  EXPECT_EQ(end.directory_bytes, fs::file_size(files[0]));
  EXPECT_EQ(end.bytes_written, fs::file_size(files[0]));
}

// A full disk: a 256 KiB tmpfs (needs root: CI runs as root; skipped otherwise).
TEST(Recorder, AFullDiskIsLoggedOnceCountedAndTheFileStaysReadable) {
  TempDir dir;
  const fs::path mnt = dir.path / "small";
  fs::create_directories(mnt);
  if (::geteuid() != 0 || ::mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=256k") != 0) {
    GTEST_SKIP() << "needs root to mount a small tmpfs (CI runs as root)";
  }
  struct Unmount {
    fs::path p;
    ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
  } unmount{mnt};
  RecorderSettings settings;
  settings.directory = mnt.string();
  settings.loop_decimation = 1;
  settings.max_bytes = 64ULL << 20;  // the disk, not the budget, is the limit
  Logged log;
  Recorder r(settings, log.sink());
  r.start();
  std::uint64_t cycle = 0;
  ASSERT_TRUE(eventually([&] {
    for (int i = 0; i < 5; ++i)
      offer(r, sample(++cycle));  // ~40 KB per write
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return r.counters().disk_full;
  }));
  // It goes on: inputs accepted and counted, nothing thrown, logged once.
  for (int i = 0; i < 2000; ++i)
    offer(r, sample(++cycle));
  ASSERT_TRUE(eventually([&] { return r.counters().write_failures > 0; }));
  r.stop();
  EXPECT_EQ(log.size(), 1U) << "logged once per episode";
  const auto c = r.counters();
  EXPECT_TRUE(c.disk_full);
  EXPECT_EQ(c.mode, RecorderMode::kDiskFull) << "the refusal stays said after the stop";
  EXPECT_GE(c.disk_refusals, 1U);
  EXPECT_TRUE(c.file.empty());
  EXPECT_EQ(c.loop_samples, cycle);
  // The file the disk refused was cut back to its last whole record: it reads to the end.
  const auto files = recordings(mnt);
  ASSERT_FALSE(files.empty());
  const auto bytes = test::file_bytes(files.front());
  const auto f = test::read_mcap(bytes);
  EXPECT_TRUE(f.magic);
  EXPECT_GT(f.counts.count(kLoopChannel) ? f.counts.at(kLoopChannel) : 0U, 0U);
}

}  // namespace
}  // namespace ajar::recorder
