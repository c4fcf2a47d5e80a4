// Recorder (recorder.hpp): the recorder thread, its files, rotation, the disk's refusals.
#include "ajar/recorder/recorder.hpp"

#include <pthread.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <system_error>

#include "ajar/core/error.hpp"
#include "ajar/recorder/channels.hpp"
#include "ajar/recorder/mcap_writer.hpp"

namespace ajar::recorder {
namespace fs = std::filesystem;
namespace {

constexpr std::int64_t kWakeNs = 20'000'000;
constexpr std::int64_t kWriteEveryNs = 100'000'000;
// The writer's buffer is written out once it holds kWriteAtBytes (and at least every
// kWriteEveryNs); its capacity, reserved once per file, covers that plus a large record, and stays
// below glibc's mmap threshold (128 KiB) so that it is neither mapped nor unmapped per file.
constexpr std::size_t kWriteAtBytes = 64U << 10;
constexpr std::size_t kWriteBufferBytes = kWriteAtBytes + (32U << 10);
constexpr std::int64_t kSyncEveryNs = 1'000'000'000;
constexpr std::int64_t kStatusEveryNs = 1'000'000'000;
constexpr std::int64_t kRetryNs = 5'000'000'000;

std::int64_t clock_ns(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

constexpr std::string_view kPrefix = "ajard-";
constexpr std::string_view kSuffix = ".mcap";

std::string file_name_for(std::int64_t unix_ns) {
  const time_t secs = static_cast<time_t>(unix_ns / 1'000'000'000);
  tm utc{};
  ::gmtime_r(&secs, &utc);
  char buf[64];
  std::snprintf(buf, sizeof buf, "ajard-%04d%02d%02dT%02d%02d%02d%03dZ.mcap", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                static_cast<int>(unix_ns / 1'000'000 % 1000));
  return buf;
}

// The start time a recording's name carries (0 if it is not one of ours).
std::int64_t start_of(std::string_view name) {
  if (name.size() != kPrefix.size() + 19 + kSuffix.size() || !name.starts_with(kPrefix) ||
      !name.ends_with(kSuffix)) {
    return 0;
  }
  tm utc{};
  int ms = 0;
  if (std::sscanf(std::string(name.substr(kPrefix.size())).c_str(), "%4d%2d%2dT%2d%2d%2d%3dZ",
                  &utc.tm_year, &utc.tm_mon, &utc.tm_mday, &utc.tm_hour, &utc.tm_min, &utc.tm_sec,
                  &ms) != 7) {
    return 0;
  }
  utc.tm_year -= 1900;
  utc.tm_mon -= 1;
  return std::int64_t{::timegm(&utc)} * 1'000'000'000 + std::int64_t{ms} * 1'000'000;
}

std::string_view motion_word(std::uint8_t m) {
  static constexpr std::string_view words[] = {"idle", "moving", "jogging", "stopping"};
  return m < 4 ? words[m] : "idle";
}
std::string_view phase_word(std::uint8_t p) {
  static constexpr std::string_view words[] = {"none", "running", "coming_to_rest", "recovering"};
  return p < 4 ? words[p] : "none";
}

void append_number(std::string& out, double v) {
  if (!std::isfinite(v) || v == 0) v = 0;  // JSON has no NaN (the loop makes none); -0 -> 0
  char buf[32];
  const int n = std::snprintf(buf, sizeof buf, "%.9g", v);
  out.append(buf, static_cast<std::size_t>(n));
}
void append_integer(std::string& out, std::int64_t v) {
  out += std::to_string(v);
}
void append_unsigned(std::string& out, std::uint64_t v) {
  out += std::to_string(v);
}

struct IoRecord {
  std::uint16_t channel = 0;
  std::uint64_t daemon_time_ns = 0;
  std::vector<std::uint8_t> data;  // the message (not for a shared frame)
  // A shared frame (frame() with shared bytes): its /ajar/wire header, then the shared bytes.
  std::array<std::uint8_t, kWireHeaderBytes> wire_header{};
  std::shared_ptr<const std::vector<std::uint8_t>> shared;

  // What the queue's byte budget counts: a shared frame as a copy would be.
  std::size_t size_bytes() const {
    return shared ? kWireHeaderBytes + shared->size() : data.size();
  }
};

// The /ajar/wire header (channels.hpp) of a frame, into out[0, kWireHeaderBytes).
void put_wire_header(std::uint8_t* out, std::uint8_t direction, std::uint64_t session_id,
                     std::uint64_t daemon_time_ns) {
  out[0] = kWireLayoutVersion;
  out[1] = direction;
  for (std::size_t i = 0; i < 8; ++i) {
    out[2 + i] = static_cast<std::uint8_t>(session_id >> (8 * i));
    out[10 + i] = static_cast<std::uint8_t>(daemon_time_ns >> (8 * i));
  }
}

// The counters are written by one thread each (the recorder thread; io_* under the queue's
// mutex) and read by any: relaxed atomics.
using Counter = std::atomic<std::uint64_t>;
void bump(Counter& c, std::uint64_t n = 1) {
  c.fetch_add(n, std::memory_order_relaxed);
}
std::uint64_t get(const Counter& c) {
  return c.load(std::memory_order_relaxed);
}

std::uint64_t free_bytes(const fs::path& dir) {
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) != 0) return 0;
  return std::uint64_t{st.f_bavail} * std::uint64_t{st.f_frsize};
}

}  // namespace

std::string json_string(std::string_view text) {
  std::string out = "\"";
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  out += '"';
  return out;
}

struct Recorder::Impl {
  Recorder& self;
  Log log;
  fs::path dir;
  std::int64_t wall_minus_mono_ns = 0;

  // The queue (any thread -> recorder thread), open while the thread runs.
  std::atomic<bool> accepting{false};
  mutable std::mutex queue_mutex;
  std::vector<IoRecord> queue;
  std::size_t queue_bytes = 0;
  Counter io_records{0}, io_dropped{0};  // written under queue_mutex

  // The thread.
  std::mutex wake_mutex;
  std::condition_variable wake;
  bool stopping = false;
  std::thread thread;
  struct SaveRequest {
    double seconds;
    std::function<void(SaveResult)> done;
  };
  std::deque<SaveRequest> saves;  // under wake_mutex

  // Recorder-thread state.
  int fd = -1;
  std::unique_ptr<McapWriter> writer;
  std::string file;
  std::uint64_t on_disk = 0;             // bytes of the open file on disk
  std::uint64_t unwritten_messages = 0;  // messages in the writer's buffer
  std::int64_t file_start_mono = 0, last_write = 0, last_sync = 0, last_status = 0;
  std::int64_t retry_at = 0;
  bool failure_logged = false;
  std::string last_status_text;

  // Counters (counters(), any thread). Written by the recorder thread (and start()).
  std::atomic<RecorderMode> mode{RecorderMode::kOff};
  Counter write_failures{0}, messages_written{0}, bytes_written{0};
  Counter file_bytes{0};    // on_disk, for other threads
  Counter closed_bytes{0};  // the unsaved recordings but the open file, at the last scan
  Counter saved_bytes{0}, disk_free{0}, last_write_ns{0};
  std::atomic<std::uint32_t> refusals{0};
  mutable std::mutex file_mutex;  // held for a copy of the name, never across I/O
  std::string current_file;       // the open file's name (counters())

  Impl(Recorder& r, Log l) : self(r), log(std::move(l)), dir(r.settings_.directory) {}

  std::uint64_t daemon_ns(std::int64_t mono) const {
    return mono > self.settings_.monotonic_origin_ns
               ? static_cast<std::uint64_t>(mono - self.settings_.monotonic_origin_ns)
               : 0;
  }
  std::uint64_t wall_of_daemon(std::uint64_t daemon_time_ns) const {
    return static_cast<std::uint64_t>(self.settings_.monotonic_origin_ns + wall_minus_mono_ns) +
           daemon_time_ns;
  }

  void set_file(RecorderMode m, const std::string& name) {
    {
      std::lock_guard lock(file_mutex);
      current_file = name;
    }
    mode.store(m, std::memory_order_relaxed);
  }

  // ---- files ----
  bool open_file() {
    const std::int64_t now_wall = clock_ns(CLOCK_REALTIME);
    std::string name = file_name_for(now_wall);
    // Two files in one millisecond (a rotation right after a save): the next millisecond's name.
    for (std::int64_t bump = 1; fs::exists(dir / name) && bump < 1000; ++bump) {
      name = file_name_for(now_wall + bump * 1'000'000);
    }
    const int f = ::open((dir / name).c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0640);
    if (f < 0) {
      failed("cannot create " + (dir / name).string() + ": " + std::strerror(errno), errno);
      return false;
    }
    ::fchmod(f, 0640);  // whatever the umask
    fd = f;
    file = name;
    on_disk = 0;
    unwritten_messages = 0;
    writer = std::make_unique<McapWriter>(kMcapProfile, kMcapLibrary);
    writer->reserve(kWriteBufferBytes);
    writer->add_ajar_channels();
    file_bytes.store(0, std::memory_order_relaxed);
    file_start_mono = clock_ns(CLOCK_MONOTONIC);
    set_file(RecorderMode::kRecording, name);
    failure_logged = false;
    last_status_text.clear();
    status_message(true);
    return write_out();
  }

  // Moves the writer's bytes to the file. A refused write cuts the file back to its last whole
  // record and closes it.
  // The writer's buffer is written from where it is and then cleared, keeping its capacity: one
  // buffer of about kWriteAtBytes per file, never a new one per write.
  bool write_out() {
    if (fd < 0 || writer == nullptr) return false;
    const std::vector<std::uint8_t>& bytes = writer->pending();
    const std::uint64_t messages = unwritten_messages;
    unwritten_messages = 0;
    std::size_t done = 0;
    while (done < bytes.size()) {
      if (self.settings_.write_delay_ms > 0) {  // tests: a slow disk, cut short by stop()
        std::unique_lock lock(wake_mutex);
        wake.wait_for(lock, std::chrono::milliseconds(self.settings_.write_delay_ms),
                      [&] { return stopping; });
      }
      const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const int e = n < 0 ? errno : ENOSPC;
        (void)::ftruncate(fd, static_cast<off_t>(on_disk));
        ::close(fd);
        fd = -1;
        writer.reset();
        bump(write_failures, messages);
        failed("writing " + (dir / file).string() + " failed: " + std::strerror(e), e);
        return false;
      }
      done += static_cast<std::size_t>(n);
    }
    const std::size_t written = bytes.size();
    writer->clear_pending();
    on_disk += written;
    last_write = clock_ns(CLOCK_MONOTONIC);
    file_bytes.store(on_disk, std::memory_order_relaxed);
    bump(bytes_written, written);
    bump(messages_written, messages);
    last_write_ns.store(daemon_ns(last_write), std::memory_order_relaxed);
    return true;
  }

  void failed(const std::string& what, int error) {
    set_file(
        error == ENOSPC || error == EDQUOT ? RecorderMode::kDiskFull : RecorderMode::kDiskError,
        "");
    refusals.fetch_add(1, std::memory_order_relaxed);
    closed_bytes.fetch_add(on_disk, std::memory_order_relaxed);  // what the cut file keeps
    on_disk = 0;
    file_bytes.store(0, std::memory_order_relaxed);
    file.clear();
    retry_at = clock_ns(CLOCK_MONOTONIC) + kRetryNs;
    if (!failure_logged) {
      failure_logged = true;
      log("recorder: " + what +
          "; recording paused (records are counted as lost), retrying every " +
          "5 s; the daemon is not affected");
    }
  }

  void close_file() {
    if (fd < 0) return;
    status_message(true);
    if (fd < 0 || writer == nullptr) return;  // that last write failed: closed by failed()
    writer->close();
    if (write_out()) {
      ::fdatasync(fd);
      ::close(fd);
      fd = -1;
    }
    writer.reset();
    file.clear();
    closed_bytes.fetch_add(on_disk, std::memory_order_relaxed);
    on_disk = 0;
    file_bytes.store(0, std::memory_order_relaxed);
    if (mode.load(std::memory_order_relaxed) == RecorderMode::kRecording)
      set_file(RecorderMode::kOff, "");  // not after a refusal: its mode stays
  }

  // Closes the file (footer), removes the oldest recordings beyond the budget, starts the next.
  bool rotating = false;
  void rotate() {
    rotating = true;
    close_file();
    enforce_budget(false);
    open_file();
    rotating = false;
  }

  // Removes the oldest recordings (not saved, not open) until the rest fit max_bytes.
  // `at_least_one`: remove one even if within budget (to make room on a full disk).
  // Then counts what stays (closed_bytes, saved_bytes) and the free space.
  void enforce_budget(bool at_least_one) {
    std::vector<std::pair<std::string, std::uint64_t>> files;
    std::uint64_t total = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      if (start_of(name) == 0 || !e.is_regular_file(ec)) continue;
      const auto size = e.file_size(ec);
      if (ec) continue;
      total += size;
      if (name != file) files.emplace_back(name, size);
    }
    std::sort(files.begin(), files.end());  // the name is the start time: oldest first
    std::uint64_t closed = 0;
    for (const auto& [name, size] : files)
      closed += size;
    for (const auto& [name, size] : files) {
      if (total <= self.settings_.max_bytes && !at_least_one) break;
      at_least_one = false;
      if (fs::remove(dir / name, ec)) total -= size, closed -= size;
    }
    closed_bytes.store(closed, std::memory_order_relaxed);
    count_saved();
    disk_free.store(free_bytes(dir), std::memory_order_relaxed);
  }
  void count_saved() {
    std::uint64_t saved = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir / "saved", ec)) {
      if (start_of(e.path().filename().string()) == 0 || !e.is_regular_file(ec)) continue;
      const auto size = e.file_size(ec);
      if (!ec) saved += size;
    }
    saved_bytes.store(saved, std::memory_order_relaxed);
  }

  // ---- messages ----
  void add(std::uint16_t channel, std::uint64_t daemon_time_ns, std::span<const std::uint8_t> head,
           std::span<const std::uint8_t> data) {
    if (writer == nullptr) {
      bump(write_failures);
      return;
    }
    if (writer->offset() >= self.settings_.max_file_bytes && !rotating) {
      rotate();
      if (writer == nullptr) {
        bump(write_failures);
        return;
      }
    }
    writer->add_message(channel, wall_of_daemon(daemon_time_ns), head, data);
    ++unwritten_messages;
    // Written as soon as there is a buffer's worth (a burst of frames between two wake-ups), so
    // that the buffer never grows beyond about kWriteBufferBytes.
    if (writer->pending().size() >= kWriteAtBytes) write_out();
  }
  void add_text(std::uint16_t channel, std::uint64_t daemon_time_ns, const std::string& text) {
    add(channel, daemon_time_ns, {},
        std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  }

  void loop_message(const LoopSample& s, std::string& out) {
    out.clear();
    out += "{\"cycle\":";
    append_unsigned(out, s.cycle);
    out += ",\"daemon_time_ns\":";
    append_unsigned(out, daemon_ns(s.time_ns));
    for (int i = 0; i < 2; ++i) {
      out += i == 0 ? ",\"left\":{\"commanded_rad\":" : ",\"right\":{\"commanded_rad\":";
      append_number(out, s.commanded_rad[i]);
      out += ",\"measured_rad\":";
      append_number(out, s.measured_rad[i]);
      out += ",\"commanded_rad_s\":";
      append_number(out, s.commanded_rad_s[i]);
      out += ",\"measured_rad_s\":";
      append_number(out, s.measured_rad_s[i]);
      out += ",\"counts\":";
      append_integer(out, s.counts[i]);
      out += '}';
    }
    out += ",\"motion\":\"";
    out += motion_word(s.motion);
    out += "\",\"phase\":\"";
    out += phase_word(s.phase);
    out += "\",\"motion_id\":";
    append_unsigned(out, s.motion_id);
    out += ",\"stop_generation\":";
    append_unsigned(out, s.stop_generation);
    out += ",\"fault\":\"";
    out += to_string(static_cast<ErrorCode>(s.fault));
    out += "\",\"pose\":{\"x_m\":";
    append_number(out, s.x_m);
    out += ",\"y_m\":";
    append_number(out, s.y_m);
    out += ",\"yaw_rad\":";
    append_number(out, s.yaw_rad);
    out += "},\"commanded_linear_m_s\":";
    append_number(out, s.commanded_linear_m_s);
    out += ",\"commanded_angular_rad_s\":";
    append_number(out, s.commanded_angular_rad_s);
    out += ",\"timing\":{\"wakeup_latency_ns\":";
    append_integer(out, s.wakeup_latency_ns);
    out += ",\"execution_ns\":";
    append_integer(out, s.execution_ns);
    out += ",\"period_ns\":";
    append_integer(out, s.period_ns);
    out += "}}";
  }

  // The recorder's counters on /ajar/recorder: at a file's start and end (`force`), else when
  // they changed.
  void status_message(bool force) {
    const RecorderCounters c = self.counters();
    std::string text = "{\"daemon_time_ns\":";
    const std::size_t time_end = text.size();
    text += ",\"loop_samples\":" + std::to_string(c.loop_samples) +
            ",\"loop_dropped\":" + std::to_string(c.loop_dropped) +
            ",\"io_records\":" + std::to_string(c.io_records) +
            ",\"io_dropped\":" + std::to_string(c.io_dropped) +
            ",\"write_failures\":" + std::to_string(c.write_failures) +
            ",\"disk_full\":" + (c.disk_full ? "true" : "false") +
            ",\"file\":" + json_string(file) + "}";
    // Compared without the samples taken (they always change) and the time.
    std::string key = text.substr(time_end);
    key.erase(0, key.find(",\"loop_dropped\""));
    if (!force && key == last_status_text) return;
    last_status_text = key;
    const std::uint64_t now = daemon_ns(clock_ns(CLOCK_MONOTONIC));
    text.insert(time_end, std::to_string(now));
    add_text(kRecorderChannel, now, text);
  }

  // ---- the thread ----
  void run() {
    std::string text;
    std::vector<IoRecord> batch;
    open_file();
    for (;;) {
      bool stop_now = false;
      std::deque<SaveRequest> save_now;
      {
        std::unique_lock lock(wake_mutex);
        wake.wait_for(lock, std::chrono::nanoseconds(kWakeNs),
                      [&] { return stopping || !saves.empty(); });
        stop_now = stopping;
        save_now.swap(saves);
      }
      const std::int64_t now = clock_ns(CLOCK_MONOTONIC);
      if (fd < 0 && !stop_now && now >= retry_at) {
        enforce_budget(disk_full_now());
        open_file();
      }
      LoopSample s;
      while (self.ring_.pop(s)) {
        if (writer == nullptr) {
          bump(write_failures);
          continue;
        }
        loop_message(s, text);
        add_text(kLoopChannel, daemon_ns(s.time_ns), text);
      }
      {
        std::lock_guard lock(queue_mutex);
        batch.swap(queue);
        queue_bytes = 0;
      }
      for (const auto& r : batch) {
        if (r.shared) {
          add(r.channel, r.daemon_time_ns, r.wire_header, *r.shared);
        } else {
          add(r.channel, r.daemon_time_ns, {}, r.data);
        }
      }
      batch.clear();
      if (now - last_status >= kStatusEveryNs) {
        last_status = now;
        disk_free.store(free_bytes(dir), std::memory_order_relaxed);
        if (writer != nullptr) status_message(false);
      }
      if (writer != nullptr &&
          (writer->pending().size() >= kWriteAtBytes || now - last_write >= kWriteEveryNs)) {
        write_out();
      }
      if (fd >= 0 && now - last_sync >= kSyncEveryNs) {
        ::fdatasync(fd);
        last_sync = now;
      }
      if (fd >= 0 &&
          static_cast<double>(now - file_start_mono) / 1e9 >= self.settings_.max_file_s) {
        rotate();  // by age (by size: add())
      }
      for (auto& request : save_now)
        save(request);
      if (stop_now) break;
    }
    close_file();
  }

  bool disk_full_now() const {
    return mode.load(std::memory_order_relaxed) == RecorderMode::kDiskFull;
  }

  // frame() and json(): into the queue, or dropped and counted when it is full.
  void enqueue(IoRecord r) {
    const std::size_t size = r.size_bytes();
    std::lock_guard lock(queue_mutex);
    if (queue.size() >= kIoQueueMaxRecords || queue_bytes + size > kIoQueueMaxBytes) {
      bump(io_dropped);
      return;
    }
    queue_bytes += size;
    queue.push_back(std::move(r));
    bump(io_records);
  }

  void save(SaveRequest& request) {
    SaveResult result;
    const std::int64_t now_wall = clock_ns(CLOCK_REALTIME);
    const std::int64_t from = now_wall - static_cast<std::int64_t>(request.seconds * 1e9);
    close_file();  // the active file gets its footer; the next one starts below
    std::error_code ec;
    fs::create_directories(dir / "saved", ec);
    ::chmod((dir / "saved").c_str(), 0750);
    std::vector<RecordingInfo> all = self.list();
    for (std::size_t i = 0; i < all.size(); ++i) {
      const auto& r = all[i];
      if (r.saved) continue;
      if (r.end_unix_ns < from) continue;  // ended before the window
      const fs::path target = dir / "saved" / r.name;
      if (!fs::exists(target, ec)) fs::create_hard_link(dir / r.name, target, ec);
      if (ec) {
        result.error = "cannot save " + r.name + ": " + ec.message();
        break;
      }
      result.names.push_back("saved/" + r.name);
    }
    result.ok = result.error.empty();
    count_saved();
    open_file();
    if (request.done) request.done(std::move(result));
  }
};

Recorder::Recorder(RecorderSettings settings, Log log)
    : settings_(std::move(settings)), impl_(std::make_unique<Impl>(*this, std::move(log))) {
  if (settings_.loop_decimation == 0) settings_.loop_decimation = 1;
}

Recorder::~Recorder() {
  stop();
}

void Recorder::start() {
  if (!settings_.enabled || impl_->thread.joinable()) return;
  std::error_code ec;
  fs::create_directories(impl_->dir, ec);
  if (ec || ::access(impl_->dir.c_str(), W_OK) != 0) {
    impl_->set_file(RecorderMode::kNoDirectory, "");
    impl_->log("recorder: cannot use the directory " + impl_->dir.string() + " (" +
               (ec ? ec.message() : std::string(std::strerror(errno))) +
               "); recording is off, the daemon runs on");
    return;
  }
  ::chmod(impl_->dir.c_str(), 0750);
  impl_->wall_minus_mono_ns = clock_ns(CLOCK_REALTIME) - clock_ns(CLOCK_MONOTONIC);
  impl_->enforce_budget(false);
  impl_->thread = std::thread([this] {  // it opens the first file
    pthread_setname_np(pthread_self(), "ajar-recorder");
    impl_->run();
  });
  impl_->accepting.store(true, std::memory_order_release);
}

void Recorder::stop() {
  if (!impl_->thread.joinable()) return;
  impl_->accepting.store(false, std::memory_order_release);
  {
    std::lock_guard lock(impl_->wake_mutex);
    impl_->stopping = true;
  }
  impl_->wake.notify_all();
  impl_->thread.join();
  // Saves asked for after the thread ended: answered here.
  for (auto& request : impl_->saves) {
    if (request.done) request.done({false, {}, "the recorder stopped"});
  }
  impl_->saves.clear();
}

void Recorder::loop_sample(const LoopSample& sample) noexcept {
  if (settings_.enabled) ring_.push(sample);
}

void Recorder::frame(std::uint8_t direction, std::uint64_t session_id, std::uint64_t daemon_time_ns,
                     std::span<const std::uint8_t> bytes) {
  if (!impl_->accepting.load(std::memory_order_acquire)) return;  // off, or not running
  IoRecord r;
  r.channel = kWireChannel;
  r.daemon_time_ns = daemon_time_ns;
  r.data.resize(kWireHeaderBytes + bytes.size());
  put_wire_header(r.data.data(), direction, session_id, daemon_time_ns);
  std::copy(bytes.begin(), bytes.end(), r.data.begin() + kWireHeaderBytes);
  impl_->enqueue(std::move(r));
}

void Recorder::frame(std::uint8_t direction, std::uint64_t session_id, std::uint64_t daemon_time_ns,
                     std::shared_ptr<const std::vector<std::uint8_t>> bytes) {
  if (!impl_->accepting.load(std::memory_order_acquire) || !bytes) return;  // off, not running
  IoRecord r;
  r.channel = kWireChannel;
  r.daemon_time_ns = daemon_time_ns;
  put_wire_header(r.wire_header.data(), direction, session_id, daemon_time_ns);
  r.shared = std::move(bytes);
  impl_->enqueue(std::move(r));
}

void Recorder::json(std::uint16_t channel, std::uint64_t daemon_time_ns, std::string text) {
  if (!impl_->accepting.load(std::memory_order_acquire)) return;  // off, or not running
  IoRecord r;
  r.channel = channel;
  r.daemon_time_ns = daemon_time_ns;
  r.data.assign(text.begin(), text.end());
  impl_->enqueue(std::move(r));
}

RecorderCounters Recorder::counters() const {
  const Impl& m = *impl_;
  RecorderCounters c;
  c.enabled = settings_.enabled;
  c.mode = m.mode.load(std::memory_order_relaxed);
  c.recording = c.mode == RecorderMode::kRecording;
  c.disk_full = c.mode == RecorderMode::kDiskFull;
  // Dropped first: a sample counted dropped is then also counted taken (dropped <= samples).
  c.loop_dropped = ring_.dropped();
  c.loop_samples = ring_.pushed() + c.loop_dropped;
  c.io_dropped = get(m.io_dropped);
  c.io_records = get(m.io_records);
  c.write_failures = get(m.write_failures);
  c.disk_refusals = m.refusals.load(std::memory_order_relaxed);
  c.messages_written = get(m.messages_written);
  c.bytes_written = get(m.bytes_written);
  c.file_bytes = get(m.file_bytes);
  c.directory_bytes = get(m.closed_bytes) + c.file_bytes;
  c.saved_bytes = get(m.saved_bytes);
  c.disk_free_bytes = get(m.disk_free);
  c.last_write_ns = get(m.last_write_ns);
  std::lock_guard lock(m.file_mutex);
  c.file = m.current_file;
  return c;
}

std::vector<RecordingInfo> Recorder::list() const {
  std::vector<RecordingInfo> out;
  const auto scan = [&](const fs::path& where, bool saved) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(where, ec)) {
      const std::string name = e.path().filename().string();
      const std::int64_t start = start_of(name);
      if (start == 0 || !e.is_regular_file(ec)) continue;
      struct stat st {};
      if (::stat(e.path().c_str(), &st) != 0) continue;
      RecordingInfo r;
      r.name = saved ? "saved/" + name : name;
      r.bytes = static_cast<std::uint64_t>(st.st_size);
      r.start_unix_ns = start;
      r.end_unix_ns = std::int64_t{st.st_mtim.tv_sec} * 1'000'000'000 + st.st_mtim.tv_nsec;
      r.saved = saved;
      out.push_back(std::move(r));
    }
  };
  scan(impl_->dir, false);
  scan(impl_->dir / "saved", true);
  std::sort(out.begin(), out.end(), [](const RecordingInfo& a, const RecordingInfo& b) {
    return a.saved != b.saved ? !a.saved : a.name < b.name;
  });
  // The newest unsaved one is the active file while recording.
  const RecorderCounters c = counters();
  if (c.recording) {
    for (auto it = out.rbegin(); it != out.rend(); ++it) {
      if (!it->saved) {
        it->active = true;
        break;
      }
    }
  }
  return out;
}

std::optional<std::vector<std::uint8_t>> Recorder::read(std::string_view name, std::uint64_t offset,
                                                        std::size_t max_bytes,
                                                        std::string* error) const {
  std::string_view base = name;
  const bool saved = base.starts_with("saved/");
  if (saved) base.remove_prefix(6);
  if (start_of(base) == 0 || base.find('/') != std::string_view::npos) {
    if (error) *error = "not a recording: " + std::string(name);
    return std::nullopt;
  }
  const fs::path path = saved ? impl_->dir / "saved" / base : impl_->dir / base;
  const int f = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (f < 0) {
    if (error) *error = "no recording " + std::string(name) + ": " + std::strerror(errno);
    return std::nullopt;
  }
  std::vector<std::uint8_t> out(max_bytes);
  std::size_t got = 0;
  while (got < max_bytes) {
    const ssize_t n =
        ::pread(f, out.data() + got, max_bytes - got, static_cast<off_t>(offset + got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  ::close(f);
  out.resize(got);
  return out;
}

void Recorder::save_last(double seconds, std::function<void(SaveResult)> done) {
  if (!settings_.enabled || !impl_->thread.joinable()) {
    if (done) done({false, {}, "the recorder is off"});
    return;
  }
  {
    std::lock_guard lock(impl_->wake_mutex);
    impl_->saves.push_back({seconds, std::move(done)});
  }
  impl_->wake.notify_all();
}

}  // namespace ajar::recorder
