// Recorder: ajard's black box (docs/blackbox.md). Writes the channels of channels.hpp into MCAP
// files (mcap_writer.hpp) in one directory, from a thread of its own.
//
// Inputs, none of which ever waits for the disk:
//   - loop_sample() (the control thread, the single producer): every loop_decimation-th call is
//     copied into a fixed-size lock-free ring (SpscRing): no allocation, no lock, no system call.
//     A full ring drops the sample and counts it (loop_dropped).
//   - frame() / json() (any other thread: the I/O thread, the engine): a bounded queue (kIoQueue*
//     below; a mutex held for a push or a swap, never across I/O). A full queue drops the record
//     and counts it (io_dropped).
// The recorder thread wakes every 20 ms, drains both into the file's writer, writes to the file at
// least every 100 ms and fdatasync()s it at least every second: after a kill -9 the file holds
// everything up to at most ~0.1 s before it (the records still in memory), after a power loss at
// most ~1 s. A file cut anywhere is readable up to its last whole record (no footer needed);
// a file closed normally (rotation, stop) has Data End, summary and Footer.
//
// Bounded: a file is closed and a new one started at max_file_bytes or max_file_s; after each
// rotation the oldest recordings in the directory are removed until the rest fit max_bytes.
// Saved recordings (save_last(), in directory/saved/) are never removed by the recorder.
// A disk that refuses a write (full, I/O error): the file is cut back to its last whole record and
// closed, the failure is logged once (the `log` callback) and counted (disk_refusals; the records
// in write_failures, also those taken while no file is open), and a new file is tried every 5 s
// (after removing the oldest recording, to make room). A slow disk only delays the recorder thread:
// the inputs drop and count once their ring/queue is full. Nothing here ever fails or slows the
// daemon.
//
// Files: directory/ajard-YYYYMMDDTHHMMSSmmmZ.mcap (UTC start time), created by the daemon's user
// with mode 0640 (the directory 0750), like the state file.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "ajar/recorder/spsc_ring.hpp"

namespace ajar::recorder {

struct RecorderSettings {
  bool enabled = true;
  std::string directory;                       // created if missing (0750)
  std::uint64_t max_bytes = 512ULL << 20;      // every recording but the saved ones
  std::uint64_t max_file_bytes = 64ULL << 20;  // rotate at this size ...
  double max_file_s = 600;                     // ... or this age
  std::uint32_t loop_decimation = 5;           // record every n-th loop cycle (1: all)
  std::int64_t monotonic_origin_ns = 0;        // daemon start: daemon_time_ns = t - origin
  // Tests only: the recorder thread waits this long before every write(2) (a slow or stalled
  // disk); stop() cuts the wait short. Nothing else ever waits for it.
  std::int64_t write_delay_ms = 0;
};

// One loop cycle as the control thread hands it over (fixed size, trivially copyable).
struct LoopSample {
  std::uint64_t cycle = 0;
  std::int64_t time_ns = 0;  // the cycle's wake-up, CLOCK_MONOTONIC
  double commanded_rad[2] = {0, 0}, measured_rad[2] = {0, 0};  // left, right; wheel-forward
  double commanded_rad_s[2] = {0, 0}, measured_rad_s[2] = {0, 0};
  std::int64_t counts[2] = {0, 0};
  double x_m = 0, y_m = 0, yaw_rad = 0;
  double commanded_linear_m_s = 0, commanded_angular_rad_s = 0;
  std::uint8_t motion = 0;  // 0 idle, 1 moving, 2 jogging, 3 stopping
  std::uint8_t phase = 0;   // 0 none, 1 running, 2 coming_to_rest, 3 recovering
  std::uint16_t fault = 0;  // ajar::ErrorCode of the fault latched in the loop (0: none)
  std::uint32_t motion_id = 0;
  std::uint32_t stop_generation = 0;
  std::int64_t wakeup_latency_ns = 0, execution_ns = 0, period_ns = 0;
};

// What the recorder does now (Status.recorder.mode, protocol 1.2: the same values).
enum class RecorderMode : std::uint8_t {
  kOff = 0,          // disabled, or not started
  kRecording = 1,    // a file is open
  kDiskFull = 2,     // the disk refused for lack of space: paused, retried every 5 s
  kDiskError = 3,    // the disk refused otherwise (EIO, EACCES, ...): paused, retried every 5 s
  kNoDirectory = 4,  // the directory could not be made or written at start: off until a restart
};

// The recorder's counters since start (Status.recorder). Each is read from its own atomic: each is
// exact, the set is not one instant's (a record may be counted written before its bytes are).
struct RecorderCounters {
  bool enabled = false;
  RecorderMode mode = RecorderMode::kOff;
  bool recording = false;  // mode == kRecording: a file is open
  bool disk_full = false;  // mode == kDiskFull: the last write failed for lack of space
  std::uint64_t loop_samples = 0, loop_dropped = 0;  // taken; dropped at the full ring
  std::uint64_t io_records = 0, io_dropped = 0;      // queued; refused by the full queue
  std::uint64_t write_failures = 0;  // records lost to a refused write or while no file was open
  std::uint32_t disk_refusals = 0;   // refused writes and file creations
  std::uint64_t messages_written = 0, bytes_written = 0;  // since start, all files
  std::string file;                                       // the open file's name ("" if none)
  std::uint64_t file_bytes = 0;                           // the open file's bytes on disk
  std::uint64_t directory_bytes = 0;  // the unsaved recordings (the budget's count), open included
  std::uint64_t saved_bytes = 0;      // saved/ (as of the last rotation or save)
  std::uint64_t disk_free_bytes = 0;  // statvfs f_bavail of the directory (at most 1 s old)
  std::uint64_t last_write_ns = 0;    // daemon time of the last write to a file (0: none)
};

// A recording in the directory (list()).
struct RecordingInfo {
  std::string name;  // "ajard-20261126T130501123Z.mcap", or "saved/..." for a saved one
  std::uint64_t bytes = 0;
  std::int64_t start_unix_ns = 0;  // from the name
  std::int64_t end_unix_ns = 0;    // last modification
  bool active = false;             // the file being written (no footer yet)
  bool saved = false;              // in saved/: never removed by rotation
};

struct SaveResult {
  bool ok = false;
  std::vector<std::string> names;  // the saved recordings (saved/...), oldest first
  std::string error;               // when !ok
};

class Recorder {
 public:
  // Samples: 10 s at the default decimation (100 Hz), 2 s at every cycle (500 Hz); the recorder
  // thread drains it every 20 ms. 176 KiB, all of it resident once the ring has gone round.
  static constexpr std::size_t kLoopRingCapacity = 1024;
  static constexpr std::size_t kIoQueueMaxRecords = 16384;
  static constexpr std::size_t kIoQueueMaxBytes = 16U << 20;

  using Log = std::function<void(std::string_view)>;  // a warning, once per episode
  Recorder(RecorderSettings settings, Log log);
  ~Recorder();  // stop()
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Starts the recorder thread (nothing when disabled), which opens the first file: the caller
  // never waits for a write. A directory that cannot be made or written is logged and recording
  // stays off (mode kNoDirectory); the daemon runs on.
  void start();
  // Drains what is queued, closes the file with its summary and footer, joins. Idempotent.
  void stop();

  // ---- the control thread (single producer): noexcept, no allocation, lock or system call ----
  // Called every cycle: true every loop_decimation-th call (then make the sample and hand it
  // over with loop_sample()); false when disabled.
  bool take_loop_sample() noexcept {
    if (!settings_.enabled || ++decimation_count_ < settings_.loop_decimation) return false;
    decimation_count_ = 0;
    return true;
  }
  // Copies `sample` into the ring (dropped and counted when full).
  void loop_sample(const LoopSample& sample) noexcept;

  // ---- any other thread (ignored unless the recorder thread runs: between start() and stop())
  // ---- A protocol frame in or out (channels.hpp, /ajar/wire).
  void frame(std::uint8_t direction, std::uint64_t session_id, std::uint64_t daemon_time_ns,
             std::span<const std::uint8_t> bytes);
  // The same for a frame whose bytes are shared (a frame sent to many sessions, a Telemetry tick
  // to 256 observers): the queue keeps a reference to them, not a copy per session. They must not
  // change afterwards.
  void frame(std::uint8_t direction, std::uint64_t session_id, std::uint64_t daemon_time_ns,
             std::shared_ptr<const std::vector<std::uint8_t>> bytes);
  // A JSON message on a JSON channel of channels.hpp (the text must match its schema).
  void json(std::uint16_t channel, std::uint64_t daemon_time_ns, std::string text);
  RecorderCounters counters() const;
  const RecorderSettings& settings() const noexcept { return settings_; }

  // ---- the black box over the protocol (protocol handlers: the thread that also calls stop())
  // ---- Every recording in the directory and in saved/, oldest first.
  std::vector<RecordingInfo> list() const;
  // Up to `max_bytes` of recording `name` (as list() names it) from byte `offset`; a short (or
  // empty) result at the end of the file. nullopt (with `error`) when `name` is not a recording
  // there. The active file reads too: up to its last written record.
  std::optional<std::vector<std::uint8_t>> read(std::string_view name, std::uint64_t offset,
                                                std::size_t max_bytes, std::string* error) const;
  // "Save the last `seconds`": the recorder thread closes the active file (and starts the next),
  // then hard-links every recording that overlaps the last `seconds` into saved/, where rotation
  // never removes it. `done` is called once, from the recorder thread (or at once if disabled).
  void save_last(double seconds, std::function<void(SaveResult)> done);

 private:
  struct Impl;
  RecorderSettings settings_;
  SpscRing<LoopSample, kLoopRingCapacity> ring_;
  std::uint32_t decimation_count_ = 0;  // control thread only
  std::unique_ptr<Impl> impl_;
};

// JSON text helpers for the channels' messages (no dependency): `"` + escaped + `"`.
std::string json_string(std::string_view text);

}  // namespace ajar::recorder
