#include "ajar/daemon/state_store.hpp"

#include <pthread.h>
#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/protocol/codec.hpp"
#include "state_file.hpp"

namespace ajar::daemon {
namespace {

using detail::is_restorable_fault;
using detail::state_file_error;

Error bad(const std::string& message) {
  return state_file_error(message);
}

// Format 3's header (state_store.hpp): offsets and size.
constexpr std::size_t kMagicSize = 8;
constexpr std::size_t kVersionAt = 8;  // u16
constexpr std::size_t kCleanAt = 10;
constexpr std::size_t kPhaseAt = 11;
constexpr std::size_t kAlignedAt = 12;
constexpr std::size_t kPlaneConsumedAt = 13;
constexpr std::size_t kFaultAt = 14;  // u16
constexpr std::size_t kFrameCountAt = 16;
constexpr std::size_t kReservedAt = 17;
constexpr std::size_t kHeaderCrcAt = 18;  // u32: CRC-32C of bytes 0..17
constexpr std::size_t kStateHeaderSize = 22;
constexpr std::uint8_t kMaxFrames = 4;  // width, handle, plane, contact

void put_u16(std::string& out, std::size_t at, std::uint16_t v) {
  out[at] = static_cast<char>(v & 0xFF);
  out[at + 1] = static_cast<char>(v >> 8);
}

void put_u32(std::string& out, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i)
    out[at + i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}

std::uint8_t byte_at(const std::string& in, std::size_t at) {
  return static_cast<std::uint8_t>(in[at]);
}

std::uint32_t u32_at(const std::string& in, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i)
    v |= static_cast<std::uint32_t>(byte_at(in, at + i)) << (8 * i);
  return v;
}

std::uint32_t header_crc(const std::string& bytes) {
  return protocol::crc32c(std::span<const std::uint8_t>(
      reinterpret_cast<const std::uint8_t*>(bytes.data()), kHeaderCrcAt));
}

// Appends `message` as one protocol frame (request id 0, the current minor version).
void put_frame(std::string& out, const protocol::Message& message) {
  std::array<std::uint8_t, protocol::kMaxFrameSize> frame{};
  const std::size_t n = protocol::encode(protocol::Envelope{0, 0, message}, frame);
  out.append(reinterpret_cast<const char*>(frame.data()), n);
}

// The phase as the header stores it.
std::uint8_t phase_byte(Phase p) {
  switch (p) {
    case Phase::kIdle:
      return 0;
    case Phase::kAligning:
      return 1;
    case Phase::kEngaging:
      return 2;
    case Phase::kEngaged:
      return 3;
  }
  return 0;
}

Result<StateRecord> decode_binary_state(const std::string& in) {
  if (in.size() < kStateHeaderSize) return bad("shorter than its header (truncated?)");
  if (u32_at(in, kHeaderCrcAt) != header_crc(in))
    return bad("header checksum mismatch (corrupt file)");
  const unsigned version = static_cast<unsigned>(byte_at(in, kVersionAt)) |
                           static_cast<unsigned>(byte_at(in, kVersionAt + 1)) << 8;
  if (version != static_cast<unsigned>(kStateFormatVersion)) {
    return bad("unsupported format version " + std::to_string(version) +
               " (this daemon reads 1, 2 and " + std::to_string(kStateFormatVersion) + ")");
  }
  StateRecord state;
  ProcedureRecord& r = state.procedure;
  const auto flag = [&](std::size_t at, const char* name, bool& out) -> Outcome {
    const std::uint8_t b = byte_at(in, at);
    if (b > 1) return bad(std::string(name) + " is " + std::to_string(b) + ", not 0 or 1");
    out = b == 1;
    return Ok{};
  };
  if (auto s = flag(kCleanAt, "clean_shutdown", state.clean_shutdown); !s) return s.error();
  if (auto s = flag(kAlignedAt, "aligned", r.aligned); !s) return s.error();
  if (auto s = flag(kPlaneConsumedAt, "plane_consumed", r.plane_consumed); !s) return s.error();
  constexpr Phase kPhases[] = {Phase::kIdle, Phase::kAligning, Phase::kEngaging, Phase::kEngaged};
  const std::uint8_t phase = byte_at(in, kPhaseAt);
  if (phase >= std::size(kPhases)) return bad("unknown phase " + std::to_string(phase));
  r.phase = kPhases[phase];
  const unsigned fault = static_cast<unsigned>(byte_at(in, kFaultAt)) |
                         static_cast<unsigned>(byte_at(in, kFaultAt + 1)) << 8;
  if (!is_restorable_fault(fault)) {
    return bad("fault code '" + std::to_string(fault) + "' is not a fault the daemon latches");
  }
  r.fault = static_cast<ErrorCode>(fault);
  const std::uint8_t frames = byte_at(in, kFrameCountAt);
  if (frames > kMaxFrames) return bad("frame count " + std::to_string(frames) + " above 4");
  if (byte_at(in, kReservedAt) != 0) return bad("reserved header byte is not 0");
  std::size_t at = kStateHeaderSize;
  for (std::uint8_t i = 0; i < frames; ++i) {
    const auto where = "frame " + std::to_string(i + 1) + ": ";
    if (in.size() - at < protocol::kHeaderSize) return bad(where + "truncated");
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(in.data()) + at;
    const protocol::FrameHeader h = protocol::decode_header(
        std::span<const std::uint8_t, protocol::kHeaderSize>(bytes, protocol::kHeaderSize));
    if (h.payload_length > protocol::kMaxPayloadSize ||
        in.size() - at - protocol::kHeaderSize < h.payload_length) {
      return bad(where + "truncated");
    }
    const std::size_t size = protocol::kHeaderSize + h.payload_length;
    const auto decoded = protocol::decode_frame(std::span<const std::uint8_t>(bytes, size));
    if (decoded.kind != protocol::StreamDecoder::Kind::kMessage) {
      return bad(where + protocol::describe(decoded.error));
    }
    const protocol::Message& m = decoded.envelope.message;
    const auto once = [&](auto& slot, const auto& value) -> Outcome {
      if (slot)
        return bad(where + std::string(protocol::to_string(protocol::type_of(m))) +
                   " appears twice");
      slot = value;
      return Ok{};
    };
    Outcome stored = bad(where + std::string(protocol::to_string(protocol::type_of(m))) +
                         " is not a measurement the procedure keeps");
    if (const auto* w = std::get_if<protocol::MeasureDoorWidth>(&m)) stored = once(r.width, *w);
    if (const auto* h2 = std::get_if<protocol::MeasureHandle>(&m)) stored = once(r.handle, *h2);
    if (const auto* p = std::get_if<protocol::MeasureDoorPlane>(&m)) stored = once(r.plane, *p);
    if (const auto* c = std::get_if<protocol::SetContactPoint>(&m)) stored = once(r.contact, *c);
    if (!stored) return stored.error();
    at += size;
  }
  if (at != in.size()) return bad(std::to_string(in.size() - at) + " bytes after the last frame");
  return state;
}

std::string errno_text() {
  return std::strerror(errno);
}

}  // namespace

std::string encode_state(const StateRecord& state) {
  const ProcedureRecord& r = state.procedure;
  std::string out(kStateHeaderSize, '\0');
  out.replace(0, kMagicSize, kStateMagic, kMagicSize);
  put_u16(out, kVersionAt, static_cast<std::uint16_t>(kStateFormatVersion));
  out[kCleanAt] = state.clean_shutdown ? 1 : 0;
  out[kPhaseAt] = static_cast<char>(phase_byte(r.phase));
  out[kAlignedAt] = r.aligned ? 1 : 0;
  out[kPlaneConsumedAt] = r.plane_consumed ? 1 : 0;
  put_u16(out, kFaultAt, static_cast<std::uint16_t>(r.fault));
  std::uint8_t frames = 0;
  if (r.width) put_frame(out, *r.width), ++frames;
  if (r.handle) put_frame(out, *r.handle), ++frames;
  if (r.plane) put_frame(out, *r.plane), ++frames;
  if (r.contact) put_frame(out, *r.contact), ++frames;
  out[kFrameCountAt] = static_cast<char>(frames);
  put_u32(out, kHeaderCrcAt, header_crc(out));
  return out;
}

Result<StateRecord> decode_state(const std::string& bytes) {
  if (bytes.compare(0, kMagicSize, kStateMagic, kMagicSize) == 0) return decode_binary_state(bytes);
  if (bytes.rfind("ajar-state ", 0) == 0) return detail::decode_text_state(bytes);
  if (bytes.empty()) return bad("empty file");
  return bad("not an ajar state file");
}

// The writer thread's side, shared with it: a writer abandoned by stop() (a hung disk) keeps it.
struct StateStore::Writer {
  std::string directory;
  std::string path;
  Options options;

  std::mutex mutex;
  std::condition_variable wake;  // writer: work or stop
  std::condition_variable settled_cv;
  std::optional<StateRecord> pending;  // latest record not yet taken by the writer
  std::uint64_t pending_generation = 0;
  std::vector<std::string> errors;
  std::string last_error;
  bool stopping = false;
  bool finished = false;  // the writer thread returned
  std::atomic<std::uint64_t> submitted{0};
  std::atomic<std::uint64_t> settled{0};
};

namespace {

Outcome save_file(const std::string& directory, const std::string& path,
                  const StateStore::Options& options, const StateRecord& record) {
  const std::string text = encode_state(record);  // bytes
  const std::string tmp = path + ".tmp";
  // Every failure after the open removes the temporary file: no stray .tmp is left behind.
  const auto fail = [&](const std::string& what, int fd) {
    const std::string why = errno_text();
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    return bad(what + " '" + tmp + "': " + why);
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0) return bad("cannot create '" + tmp + "': " + errno_text());
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      return fail("cannot write", fd);
    }
    written += static_cast<std::size_t>(n);
  }
  if (options.debug_write_delay.count() > 0) std::this_thread::sleep_for(options.debug_write_delay);
  if (::fsync(fd) != 0) return fail("cannot fsync", fd);
  if (::close(fd) != 0) return fail("cannot close", -1);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = errno_text();
    ::unlink(tmp.c_str());
    return bad("cannot rename '" + tmp + "' to '" + path + "': " + why);
  }
  const int dir = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return bad("cannot open directory '" + directory + "': " + errno_text());
  const int rc = ::fsync(dir);
  const std::string why = rc != 0 ? errno_text() : std::string();
  const int closed = ::close(dir);
  if (rc != 0) return bad("cannot fsync directory '" + directory + "': " + why);
  if (closed != 0) return bad("cannot close directory '" + directory + "': " + errno_text());
  return Ok{};
}

}  // namespace

// The writer thread's loop: takes the latest record, saves it, settles its generation.
void StateStore::run(const std::shared_ptr<Writer>& w) {
  std::unique_lock lock(w->mutex);
  for (;;) {
    w->wake.wait(lock, [&] { return w->pending.has_value() || w->stopping; });
    if (!w->pending) break;  // stopping with nothing left to write
    StateRecord record = std::move(*w->pending);
    w->pending.reset();
    const std::uint64_t generation = w->pending_generation;
    lock.unlock();
    const Outcome saved = save_file(w->directory, w->path, w->options, record);
    lock.lock();
    if (!saved) {
      if (saved.error().message != w->last_error) w->errors.push_back(saved.error().message);
      w->last_error = saved.error().message;
    } else {
      w->last_error.clear();
    }
    w->settled.store(generation, std::memory_order_release);
    w->settled_cv.notify_all();
  }
  w->finished = true;
  w->settled_cv.notify_all();
}

StateStore::StateStore(std::string directory, Options options)
    : directory_(std::move(directory)),
      path_(directory_ + "/ajard.state"),
      options_(options),
      writer_state_(std::make_shared<Writer>()) {
  writer_state_->directory = directory_;
  writer_state_->path = path_;
  writer_state_->options = options_;
}

StateStore::~StateStore() {
  stop();
}

void StateStore::prepare() const {
  std::error_code ec;
  std::filesystem::create_directories(directory_, ec);
  if (ec || !std::filesystem::is_directory(directory_)) {
    throw StartupError("state.directory: cannot create '" + directory_ + "' (" +
                       (ec ? ec.message() : std::string("not a directory")) + ")");
  }
}

Result<StateStore::Loaded> StateStore::load() const {
  Loaded loaded;
  std::ifstream in(path_, std::ios::binary);
  if (!in) {
    if (!std::filesystem::exists(path_)) return loaded;
    return bad("cannot read '" + path_ + "'");
  }
  std::ostringstream content;
  content << in.rdbuf();
  auto r = decode_state(content.str());
  if (!r) {
    Error e = std::move(r).error();
    e.message = path_ + ": " + e.message;
    return e;
  }
  loaded.found = true;
  loaded.record = std::move(r).value();
  return loaded;
}

Result<std::string> StateStore::reject_current_file() const {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%SZ", &utc);
  std::string target = path_ + ".rejected-" + stamp;
  for (int n = 1; std::filesystem::exists(target) && n < 1000; ++n) {
    target = path_ + ".rejected-" + stamp + "-" + std::to_string(n);
  }
  std::error_code ec;
  std::filesystem::rename(path_, target, ec);
  if (ec) return bad("cannot move '" + path_ + "' to '" + target + "': " + ec.message());
  return target;
}

Outcome StateStore::save(const StateRecord& record) const {
  return save_file(directory_, path_, options_, record);
}

void StateStore::start() {
  Writer& w = *writer_state_;
  std::lock_guard lock(w.mutex);
  if (writer_.joinable() || w.stopping) return;
  writer_ = std::thread([shared = writer_state_] {
    pthread_setname_np(pthread_self(), "ajar-store");
    run(shared);
  });
}

std::uint64_t StateStore::submit(StateRecord record) {
  Writer& w = *writer_state_;
  std::uint64_t generation = 0;
  {
    std::lock_guard lock(w.mutex);
    generation = w.submitted.load(std::memory_order_relaxed) + 1;
    w.pending = std::move(record);
    w.pending_generation = generation;
    w.submitted.store(generation, std::memory_order_release);
  }
  w.wake.notify_one();
  return generation;
}

std::uint64_t StateStore::submitted() const noexcept {
  return writer_state_->submitted.load(std::memory_order_acquire);
}

std::uint64_t StateStore::settled() const noexcept {
  return writer_state_->settled.load(std::memory_order_acquire);
}

bool StateStore::flush(std::chrono::milliseconds timeout) {
  Writer& w = *writer_state_;
  std::unique_lock lock(w.mutex);
  if (!writer_.joinable()) return settled() >= submitted();
  return w.settled_cv.wait_for(lock, timeout, [&] { return settled() >= submitted(); });
}

std::vector<std::string> StateStore::take_errors() {
  Writer& w = *writer_state_;
  std::lock_guard lock(w.mutex);
  std::vector<std::string> out;
  out.swap(w.errors);
  return out;
}

bool StateStore::stop(std::chrono::milliseconds limit) {
  Writer& w = *writer_state_;
  bool finished = false;
  {
    std::unique_lock lock(w.mutex);
    if (!writer_.joinable()) return true;
    w.stopping = true;  // the writer finishes the pending record first, then returns
    w.wake.notify_one();
    finished = w.settled_cv.wait_for(lock, limit, [&] { return w.finished; });
  }
  if (finished) {
    writer_.join();
  } else {
    writer_.detach();  // inside a save that does not end: it keeps its Writer alive
  }
  return finished;
}

}  // namespace ajar::daemon
