// StateStore: the procedure's accepted parameters on disk, so that they survive a daemon restart.
// One file, `<directory>/ajard.state`, replaced atomically on every accepted change: written to
// `ajard.state.tmp`, fsync'd, renamed over the old file, then the directory is fsync'd. A crash at
// any point leaves either the old or the new file, never a mix.
//
// Format (text, versioned, docs/procedure.md):
//   ajar-state 1
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
// validation on start (Procedure::restore).
#pragma once

#include <string>

#include "ajar/core/result.hpp"
#include "ajar/daemon/procedure.hpp"

namespace ajar::daemon {

inline constexpr int kStateFormatVersion = 1;

std::string encode_state(const ProcedureRecord& record);
// Errors: kInternal with field "state_file" and a message saying what is wrong (version, line,
// checksum).
Result<ProcedureRecord> decode_state(const std::string& text);

class StateStore {
 public:
  explicit StateStore(std::string directory);

  // Creates the directory (and parents) if missing; throws StartupError naming it when it cannot.
  void prepare() const;
  const std::string& path() const noexcept { return path_; }

  // What the file holds. A missing file is not an error (std::nullopt-like: Ok with has_value
  // false is expressed by returning kOk and `found` false).
  struct Loaded {
    bool found = false;
    ProcedureRecord record;
  };
  Result<Loaded> load() const;
  // Atomic replace (see above). Error: kInternal, field "state_file", naming the path and errno.
  Status save(const ProcedureRecord& record) const;

 private:
  std::string directory_;
  std::string path_;
};

}  // namespace ajar::daemon
