// StateStore: the procedure's accepted parameters on disk, so that they survive a daemon restart,
// and how the last run ended. One file, `<directory>/ajard.state`, replaced atomically on every
// accepted change: written to `ajard.state.tmp`, fsync'd, closed (its result checked), renamed over
// the old file, then the directory is fsync'd. A crash at any point leaves either the old or the
// new file, never a mix; a failed save removes its `.tmp`.
//
// Saves run on the store's own writer thread (start()/submit()), never on the caller's: the I/O
// thread hands over a record and goes on serving. Saves are coalesced: while one is being written,
// newer submissions replace each other and only the latest is written next (a later record holds
// every earlier accepted change). Each submission gets a generation number (1, 2, ...); settled()
// is the highest generation whose save has finished — written durably, or failed (take_errors()
// says why; the next submission tries again).
//
// The clean-shutdown mark: every record is written with `clean_shutdown 0` ("running") except the
// last one of a clean shutdown. The engine writes a running record synchronously before the daemon
// serves, so a file that says 0 at start means the previous run ended any other way (crash, kill,
// watchdog abort, power loss, a shutdown whose last save did not finish).
//
// Format (text, versioned, docs/procedure.md):
//   ajar-state 2
//   clean_shutdown 0|1                                   (version 2; absent in version 1)
//   phase idle|aligning|engaging|engaged
//   aligned 0|1
//   plane_consumed 0|1
//   fault <numeric ErrorCode>
//   width <frame> <x> <y> <z> <frame> <x> <y> <z>       (optional; frame: camera|base)
//   handle <frame> <x> <y> <z> <frame> <x> <y> <z>      (optional)
//   plane <n> then n times <frame> <x> <y> <z>          (optional)
//   contact <frame> <x> <y> <z>                         (optional)
//   crc32 <8 hex digits>                                (CRC-32 of every byte before this line)
// Numbers are written in their shortest round-trip form, so a restored value is bit-identical.
// The requests are stored, not the derived values: the engine replays them through core's
// validation on start (Procedure::restore). Version 1 files (older ajard) are read; they carry no
// clean-shutdown mark, so they read as clean_shutdown false.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "ajar/core/result.hpp"
#include "ajar/daemon/procedure.hpp"

namespace ajar::daemon {

inline constexpr int kStateFormatVersion = 2;

// What the file holds: the procedure and how the run that wrote it ended.
struct StateRecord {
  ProcedureRecord procedure;
  bool clean_shutdown = false;               // true only in the last save of a clean shutdown
  int format_version = kStateFormatVersion;  // decode_state: the file's; encode_state writes 2
};

std::string encode_state(const StateRecord& record);
// As strict as a wire message: every line exactly once (clean_shutdown (version 2), phase,
// aligned, plane_consumed, fault required; the measurements at most once), finite numbers only,
// known enum words, a fault code that is kOk or a known driver/motion fault (5xx), 3..16 plane
// points; version 1 or 2. Errors: kInternal with field "state_file" and a message saying what is
// wrong (version, line, checksum, value).
Result<StateRecord> decode_state(const std::string& text);

class StateStore {
 public:
  struct Options {
    // Test and benchmark hook (not a config-file key): extra time each save spends before its
    // fsync, to model slow flash. 0 in production.
    std::chrono::milliseconds debug_write_delay{0};
  };

  explicit StateStore(std::string directory) : StateStore(std::move(directory), Options{}) {}
  StateStore(std::string directory, Options options);
  ~StateStore();  // stop()
  StateStore(const StateStore&) = delete;
  StateStore& operator=(const StateStore&) = delete;

  // Creates the directory (and parents) if missing; throws StartupError naming it when it cannot.
  void prepare() const;
  const std::string& path() const noexcept { return path_; }

  // What the file holds. A missing file is not an error (std::nullopt-like: Ok with has_value
  // false is expressed by returning kOk and `found` false).
  struct Loaded {
    bool found = false;
    StateRecord record;
  };
  Result<Loaded> load() const;
  // Moves the current file aside as `ajard.state.rejected-<UTC YYYYmmddTHHMMSS>` (a suffix -N
  // when that exists). Returns the new path, or why not.
  Result<std::string> reject_current_file() const;

  // Synchronous atomic replace on the caller's thread (see above). Error: kInternal, field
  // "state_file", naming the path and errno. Do not mix with a running writer thread.
  Outcome save(const StateRecord& record) const;

  // ---- writer thread -------------------------------------------------------------------------
  void start();  // starts the writer thread (idempotent)
  // Hands a record to the writer; returns its generation. Never blocks on the disk.
  std::uint64_t submit(StateRecord record);
  std::uint64_t submitted() const noexcept;
  std::uint64_t settled() const noexcept;
  // Waits until every submission has settled or `timeout` passed; true when settled. For shutdown.
  bool flush(std::chrono::milliseconds timeout);
  // Failures of saves since the last call; a failure repeating the previous one word for word is
  // reported once (until a save succeeds again).
  std::vector<std::string> take_errors();
  // Lets the writer finish the pending record, then joins it — waiting at most `limit`: a writer
  // still inside a save then (a hung disk) is abandoned (detached; it owns what it uses, and the
  // process may exit under it: its file is then the old one or the new one, as after a crash).
  // True when the writer finished. Idempotent.
  bool stop(std::chrono::milliseconds limit = std::chrono::seconds(5));

 private:
  struct Writer;  // shared with the writer thread, which may outlive the store (stop())
  static void run(const std::shared_ptr<Writer>& writer);  // the writer thread

  std::string directory_;
  std::string path_;
  Options options_;
  std::shared_ptr<Writer> writer_state_;
  std::thread writer_;
};

}  // namespace ajar::daemon
