#include "ajar/daemon/state_store.hpp"

#include <fcntl.h>
#include <unistd.h>

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

#include <boost/crc.hpp>

#include "ajar/daemon/config.hpp"

namespace ajar::daemon {
namespace {

constexpr const char* kMagic = "ajar-state";

std::uint32_t crc32(std::string_view bytes) {
  boost::crc_32_type crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

void put_number(std::string& out, double v) {
  char buffer[64];
  const auto r = std::to_chars(buffer, buffer + sizeof(buffer), v);
  out.push_back(' ');
  out.append(buffer, r.ptr);
}

void put_point(std::string& out, const core::FramedPoint& p) {
  out += p.frame == core::Frame::kBase ? " base" : " camera";
  for (int i = 0; i < 3; ++i)
    put_number(out, p.position_m[i]);
}

const char* phase_name(Phase p) {
  switch (p) {
    case Phase::kAligning:
      return "aligning";
    case Phase::kEngaging:
      return "engaging";
    case Phase::kEngaged:
      return "engaged";
    case Phase::kIdle:
      break;
  }
  return "idle";
}

Error bad(const std::string& message) {
  return make_error(ErrorCode::kInternal, "state_file", message);
}

// Whitespace-separated tokens of one line.
class Tokens {
 public:
  explicit Tokens(const std::string& line) {
    std::istringstream in(line);
    std::string t;
    while (in >> t)
      tokens_.push_back(t);
  }
  std::size_t size() const { return tokens_.size(); }
  const std::string& operator[](std::size_t i) const { return tokens_[i]; }

 private:
  std::vector<std::string> tokens_;
};

// Finite numbers only: "nan", "inf" and out-of-range values are refused.
bool parse_double(const std::string& s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(v);
}

// A latched fault as the engine latches it: kOk, or a known driver/motion fault (5xx).
bool is_restorable_fault(long long code) {
  if (code == 0) return true;
  if (code < 500 || code > 599) return false;
  return to_string(static_cast<ErrorCode>(code)) != "UNKNOWN";
}

bool parse_int(const std::string& s, long long& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Parses "<frame> x y z" starting at token `at`.
bool parse_point(const Tokens& t, std::size_t at, core::FramedPoint& p) {
  if (at + 4 > t.size()) return false;
  if (t[at] == "camera")
    p.frame = core::Frame::kCamera;
  else if (t[at] == "base")
    p.frame = core::Frame::kBase;
  else
    return false;
  for (int i = 0; i < 3; ++i) {
    double v = 0;
    if (!parse_double(t[at + 1 + static_cast<std::size_t>(i)], v)) return false;
    p.position_m[i] = v;
  }
  return true;
}

std::string errno_text() {
  return std::strerror(errno);
}

}  // namespace

std::string encode_state(const StateRecord& state) {
  const ProcedureRecord& r = state.procedure;
  std::string out;
  out += std::string(kMagic) + " " + std::to_string(kStateFormatVersion) + "\n";
  out += std::string("clean_shutdown ") + (state.clean_shutdown ? "1" : "0") + "\n";
  out += std::string("phase ") + phase_name(r.phase) + "\n";
  out += std::string("aligned ") + (r.aligned ? "1" : "0") + "\n";
  out += std::string("plane_consumed ") + (r.plane_consumed ? "1" : "0") + "\n";
  out += "fault " + std::to_string(static_cast<unsigned>(r.fault)) + "\n";
  if (r.width) {
    out += "width";
    put_point(out, r.width->p1_hinge);
    put_point(out, r.width->p2_moving_edge);
    out += "\n";
  }
  if (r.handle) {
    out += "handle";
    put_point(out, r.handle->p1_axis);
    put_point(out, r.handle->p2_free_end);
    out += "\n";
  }
  if (r.plane) {
    out += "plane " + std::to_string(r.plane->count);
    for (std::size_t i = 0; i < r.plane->count && i < r.plane->points.size(); ++i) {
      put_point(out, r.plane->points[i]);
    }
    out += "\n";
  }
  if (r.contact) {
    out += "contact";
    put_point(out, r.contact->contact);
    out += "\n";
  }
  char crc[32];
  std::snprintf(crc, sizeof(crc), "crc32 %08x\n", crc32(out));
  out += crc;
  return out;
}

Result<StateRecord> decode_state(const std::string& text) {
  const auto crc_at = text.rfind("crc32 ");
  if (crc_at == std::string::npos || (crc_at > 0 && text[crc_at - 1] != '\n')) {
    return bad("no checksum line (truncated?)");
  }
  const std::string body = text.substr(0, crc_at);
  const Tokens crc_line(text.substr(crc_at));
  unsigned long expected = 0;
  if (crc_line.size() != 2 ||
      std::from_chars(crc_line[1].data(), crc_line[1].data() + crc_line[1].size(), expected, 16)
              .ec != std::errc() ||
      expected != crc32(body)) {
    return bad("checksum mismatch (corrupt file)");
  }

  StateRecord state;
  ProcedureRecord& r = state.procedure;
  std::istringstream in(body);
  std::string line;
  int line_number = 0;
  bool have_header = false;
  std::set<std::string> seen;
  while (std::getline(in, line)) {
    ++line_number;
    const Tokens t(line);
    if (t.size() == 0) continue;
    const auto fail = [&](const std::string& what) {
      return bad("line " + std::to_string(line_number) + ": " + what);
    };
    if (!have_header) {
      if (t.size() != 2 || t[0] != kMagic) return fail("not an ajar state file");
      if (t[1] != "1" && t[1] != std::to_string(kStateFormatVersion)) {
        return fail("unsupported format version " + t[1] + " (this daemon reads 1 and " +
                    std::to_string(kStateFormatVersion) + ")");
      }
      state.format_version = t[1] == "1" ? 1 : kStateFormatVersion;
      have_header = true;
      continue;
    }
    const std::string& key = t[0];
    if (!seen.insert(key).second) return fail("'" + key + "' appears twice");
    if (key == "clean_shutdown" && state.format_version >= 2 && t.size() == 2 &&
        (t[1] == "0" || t[1] == "1")) {
      state.clean_shutdown = t[1] == "1";
    } else if (key == "phase" && t.size() == 2) {
      if (t[1] == "idle")
        r.phase = Phase::kIdle;
      else if (t[1] == "aligning")
        r.phase = Phase::kAligning;
      else if (t[1] == "engaging")
        r.phase = Phase::kEngaging;
      else if (t[1] == "engaged")
        r.phase = Phase::kEngaged;
      else
        return fail("unknown phase '" + t[1] + "'");
    } else if ((key == "aligned" || key == "plane_consumed") && t.size() == 2 &&
               (t[1] == "0" || t[1] == "1")) {
      (key == "aligned" ? r.aligned : r.plane_consumed) = t[1] == "1";
    } else if (key == "fault" && t.size() == 2) {
      long long code = 0;
      if (!parse_int(t[1], code) || !is_restorable_fault(code)) {
        return fail("fault code '" + t[1] + "' is not a fault the daemon latches");
      }
      r.fault = static_cast<ErrorCode>(code);
    } else if (key == "width" && t.size() == 9) {
      protocol::MeasureDoorWidth m;
      if (!parse_point(t, 1, m.p1_hinge) || !parse_point(t, 5, m.p2_moving_edge)) {
        return fail("bad width points");
      }
      r.width = m;
    } else if (key == "handle" && t.size() == 9) {
      protocol::MeasureHandle m;
      if (!parse_point(t, 1, m.p1_axis) || !parse_point(t, 5, m.p2_free_end)) {
        return fail("bad handle points");
      }
      r.handle = m;
    } else if (key == "plane" && t.size() >= 2) {
      long long n = 0;
      if (!parse_int(t[1], n) || n < static_cast<long long>(protocol::kMinPlanePoints) ||
          n > static_cast<long long>(protocol::kMaxPlanePoints) ||
          t.size() != 2 + 4 * static_cast<std::size_t>(n)) {
        return fail("bad plane point count");
      }
      protocol::MeasureDoorPlane m;
      m.count = static_cast<std::uint8_t>(n);
      for (std::size_t i = 0; i < m.count; ++i) {
        if (!parse_point(t, 2 + 4 * i, m.points[i])) return fail("bad plane point");
      }
      r.plane = m;
    } else if (key == "contact" && t.size() == 5) {
      protocol::SetContactPoint m;
      if (!parse_point(t, 1, m.contact)) return fail("bad contact point");
      r.contact = m;
    } else {
      return fail("unexpected '" + line + "'");
    }
  }
  if (!have_header) return bad("empty file");
  for (const char* required : {"clean_shutdown", "phase", "aligned", "plane_consumed", "fault"}) {
    if (state.format_version < 2 && std::string_view(required) == "clean_shutdown") continue;
    if (seen.count(required) == 0) return bad(std::string("line '") + required + "' missing");
  }
  return state;
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
  const std::string text = encode_state(record);
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
  writer_ = std::thread([shared = writer_state_] { run(shared); });
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
