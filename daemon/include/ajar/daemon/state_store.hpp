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
// The clean-shutdown mark: every record is written with clean_shutdown 0 ("running") except the
// last one of a clean shutdown. The engine writes a running record synchronously before the daemon
// serves, so a file that says 0 at start means the previous run ended any other way (crash, kill,
// watchdog abort, power loss, a shutdown whose last save did not finish).
//
// Format 3 (binary, little-endian, docs/procedure.md): a 22-byte header, then the accepted
// requests as protocol frames — the wire format's own encoding and CRC-32C (docs/protocol.md),
// request id 0, in the order width, handle, plane, contact, each at most once:
//   0  8 bytes  magic "AJARSTAT"
//   8  u16      format version (3)
//   10 u8       clean_shutdown 0|1
//   11 u8       phase: 0 idle, 1 aligning, 2 engaging, 3 engaged
//   12 u8       aligned 0|1
//   13 u8       plane_consumed 0|1
//   14 u16      latched fault (numeric ErrorCode; 0: none)
//   16 u8       number of frames that follow (0..4)
//   17 u8       reserved, 0
//   18 u32      CRC-32C of bytes 0..17
// The file ends with the last frame. The requests are stored, not the derived values: the engine
// replays them through core's validation on start (Procedure::restore); the frames keep every
// number bit for bit. Formats 1 and 2 (text, what older ajard wrote) are still read, once: a start
// on one restores it and the start's first save rewrites the file in format 3. Format 1 carries
// no clean-shutdown mark, so it reads as clean_shutdown false.
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

inline constexpr int kStateFormatVersion = 3;
inline constexpr const char* kStateMagic = "AJARSTAT";  // the first 8 bytes of format 3

// What the file holds: the procedure and how the run that wrote it ended.
struct StateRecord {
  ProcedureRecord procedure;
  bool clean_shutdown = false;               // true only in the last save of a clean shutdown
  int format_version = kStateFormatVersion;  // decode_state: the file's; encode_state writes 3
};

// The file's bytes in format 3.
std::string encode_state(const StateRecord& record);
// Format 3, or the text formats 1 and 2. As strict as a wire message: the header's checksum and
// every field in range (flags 0|1, a known phase, a fault code that is kOk or a known driver/motion
// fault (5xx)), every frame one the protocol's decoder accepts (finite numbers, 3..16 plane points,
// its CRC-32C) holding a measurement, each kind at most once, nothing after the last; formats 1
// and 2: every line exactly once, their CRC-32. Errors: kInternal with field "state_file" and a
// message saying what is wrong (version, checksum, value, frame).
Result<StateRecord> decode_state(const std::string& bytes);

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
