// The black box in ajard (docs/blackbox.md), end to end in process: on by default, it records the
// whole procedure (every channel, the counts its counters give); a 200 ms-per-write disk and a full
// disk (a 256 KiB tmpfs, when root: CI runs as root) change nothing for the loop or the sessions:
// cycles keep counting, Pings are answered, commands acked, the procedure completes, and the
// recorder counts (and reports) what it lost. No timing assertions.
#include <sys/mount.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "../recorder/mcap_read.hpp"
#include "ajar/recorder/channels.hpp"
#include "ajar/recorder/recorder.hpp"
#include "e2e_fixture.hpp"

namespace ajar::test {
namespace {
namespace fs = std::filesystem;
using protocol::ProcedureState;
using protocol::Role;

std::vector<fs::path> mcap_files(const std::string& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().extension() == ".mcap") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The sessions and the loop go on: Pings answered, cycles counting, the whole procedure acked.
void daemon_keeps_serving(InProcessDaemon& d) {
  TestClient observer(d.port());
  observer.hello(Role::kObserver);
  TestClient controller(d.port());
  ASSERT_EQ(controller.hello(Role::kController).granted_role, Role::kController);
  const auto before = controller.request_as<protocol::Status>(protocol::GetStatus{});
  for (std::uint64_t i = 1; i <= 20; ++i) {
    const auto pong = observer.request_as<protocol::Pong>(protocol::Ping{i});
    EXPECT_EQ(pong.client_time_ns, i);
  }
  run_procedure(controller);
  const auto after = controller.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_EQ(after.state, ProcedureState::kEngaged);
  EXPECT_GT(after.loop.cycles, before.loop.cycles) << "the control loop kept cycling";
}

TEST(EndToEndRecorder, OnByDefaultItRecordsTheWholeProcedureOnEveryChannel) {
  TempDir dir;
  daemon::Config config = e2e_config(drivers::DriverKind::kMock, dir.path());
  ASSERT_TRUE(config.recorder.enabled) << "config/ajard.yaml records";
  recorder::RecorderCounters counters;
  {
    InProcessDaemon d(config);
    ASSERT_NE(d.engine().recorder(), nullptr);
    daemon_keeps_serving(d);
    d.stop();  // the engine's shutdown closes the file
    counters = d.engine().recorder()->counters();
  }
  const auto files = mcap_files(config.recorder.directory);
  ASSERT_EQ(files.size(), 1U);
  const auto f = recorder::test::read_mcap(recorder::test::file_bytes(files[0]));
  EXPECT_TRUE(f.complete);
  EXPECT_EQ(f.messages.size(), counters.messages_written);
  EXPECT_EQ(counters.write_failures, 0U);
  for (const auto channel :
       {recorder::kWireChannel, recorder::kEventsChannel, recorder::kFaultsChannel,
        recorder::kConfigChannel, recorder::kSessionsChannel, recorder::kLoopChannel,
        recorder::kRecorderChannel}) {
    if (channel == recorder::kFaultsChannel) continue;  // no fault in a good procedure
    EXPECT_GT(f.counts.count(channel) ? f.counts.at(channel) : 0U, 0U)
        << recorder::channel_by_id(channel)->topic;
  }
  EXPECT_EQ(f.counts.at(recorder::kLoopChannel) + counters.loop_dropped, counters.loop_samples);
  // Frames in and out; the first frame in is a Hello, as on the wire.
  bool in = false, out = false;
  for (const auto& m : f.messages) {
    if (m.channel != recorder::kWireChannel) continue;
    (m.data[1] == recorder::kWireIn ? in : out) = true;
    EXPECT_EQ(m.data[recorder::kWireHeaderBytes], 0x41) << "frames start with AJAR";
  }
  EXPECT_TRUE(in && out);
}

TEST(EndToEndRecorder, ASlowDiskChangesNothingForTheLoopOrTheSessions) {
  TempDir dir;
  daemon::Config config = e2e_config(drivers::DriverKind::kMock, dir.path());
  config.recorder.debug_write_delay_ms = 200;  // every write to a recording waits 200 ms
  config.recorder.loop_decimation = 1;         // 500 samples/s against a crawling disk
  InProcessDaemon d(config);
  daemon_keeps_serving(d);
  const auto c = d.engine().recorder()->counters();
  EXPECT_GT(c.loop_samples, 0U);
  d.stop();
  const auto end = d.engine().recorder()->counters();
  // Whatever the disk could not take was dropped and counted, never waited for.
  const auto files = mcap_files(config.recorder.directory);
  ASSERT_FALSE(files.empty());
  std::uint64_t loop_messages = 0;
  for (const auto& p : files) {
    const auto f = recorder::test::read_mcap(recorder::test::file_bytes(p));
    if (f.counts.count(recorder::kLoopChannel))
      loop_messages += f.counts.at(recorder::kLoopChannel);
  }
  EXPECT_EQ(loop_messages + end.loop_dropped + end.write_failures, end.loop_samples);
}

TEST(EndToEndRecorder, AFullDiskChangesNothingForTheLoopOrTheSessionsAndIsReported) {
  TempDir dir;
  const std::string small = dir.path() + "/small";
  fs::create_directories(small);
  if (::geteuid() != 0 || ::mount("tmpfs", small.c_str(), "tmpfs", 0, "size=256k") != 0) {
    GTEST_SKIP() << "needs root to mount a small tmpfs (CI runs as root)";
  }
  struct Unmount {
    std::string p;
    ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
  } unmount{small};
  daemon::Config config = e2e_config(drivers::DriverKind::kMock, dir.path());
  config.recorder.directory = small;
  config.recorder.loop_decimation = 1;  // fills 256 KiB in about a second
  InProcessDaemon d(config);
  // Wait until the disk is full (bounded, generous), then the daemon must serve as ever.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!d.engine().recorder()->counters().disk_full && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(d.engine().recorder()->counters().disk_full);
  daemon_keeps_serving(d);
  const auto c = d.engine().recorder()->counters();
  EXPECT_TRUE(c.disk_full);
  EXPECT_GT(c.write_failures, 0U) << "what the full disk cost is counted";
}

// A recorder thread stalled in its first write (a hung disk; the test hook's wait ends at stop()):
// the loop's lock-free ring fills and drops, the daemon never waits for it, and Status (protocol
// 1.2) says so: recording, the file, nothing written yet, the drops — the recorder's own counters.
TEST(EndToEndRecorder, AStalledWriterDropsAndStatusReportsTheRecordersCounters) {
  TempDir dir;
  daemon::Config config = e2e_config(drivers::DriverKind::kMock, dir.path());
  config.recorder.debug_write_delay_ms = 3'600'000;  // every write waits an hour, or until stop
  config.recorder.loop_decimation = 1;               // fills the ring in ~8 s at 500 Hz
  InProcessDaemon d(config);
  TestClient observer(d.port());
  ASSERT_EQ(observer.hello(Role::kObserver).version_minor, 2);
  protocol::Status s;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(90);
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    s = observer.request_as<protocol::Status>(protocol::GetStatus{});
  } while (s.recorder.loop_dropped == 0 && std::chrono::steady_clock::now() < until);
  const auto after = d.engine().recorder()->counters();
  const protocol::RecorderState& r = s.recorder;
  EXPECT_TRUE(r.enabled);
  EXPECT_EQ(r.mode, protocol::RecorderMode::kRecording);
  EXPECT_TRUE(r.file.view().starts_with("ajard-") && r.file.view().ends_with(".mcap"))
      << r.file.view();
  EXPECT_EQ(r.records_written, 0U) << "the writer is stuck in its first write";
  EXPECT_EQ(r.last_write_ns, 0U) << "recording and no write yet: a stalled disk";
  EXPECT_EQ(r.max_bytes, static_cast<std::uint64_t>(config.recorder.max_bytes));
  ASSERT_GT(r.loop_dropped, 0U) << "a full ring drops (and Status says so)";
  EXPECT_LE(r.loop_dropped, r.loop_samples);
  EXPECT_EQ(r.loop_samples - r.loop_dropped, recorder::Recorder::kLoopRingCapacity)
      << "the ring holds exactly its capacity: everything else was dropped";
  // Status carries the recorder's counters (read before; they only grow).
  EXPECT_LE(r.loop_dropped, after.loop_dropped);
  EXPECT_LE(r.loop_samples, after.loop_samples);
  EXPECT_LE(r.io_records, after.io_records);
  EXPECT_EQ(std::string(r.file.view()), after.file);
  // The daemon goes on: the loop cycles, the sessions are served, the procedure is acked.
  daemon_keeps_serving(d);
  const auto later = observer.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_GT(later.recorder.loop_dropped, r.loop_dropped) << "the loop kept offering, and dropping";
  d.stop();  // cuts the hour short: the file is written and closed
  const auto end = d.engine().recorder()->counters();
  const auto files = mcap_files(config.recorder.directory);
  ASSERT_EQ(files.size(), 1U);
  const auto f = recorder::test::read_mcap(recorder::test::file_bytes(files[0]));
  EXPECT_EQ(f.counts.at(recorder::kLoopChannel) + end.loop_dropped + end.write_failures,
            end.loop_samples);
}

}  // namespace
}  // namespace ajar::test
