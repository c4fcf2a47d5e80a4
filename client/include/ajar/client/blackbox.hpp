// The daemon's black box over the protocol (1.2; docs/protocol.md 5.23-5.27, docs/blackbox.md):
// list the recordings, fetch one into a local file (chunked, resumable, with progress), save the
// last seconds. Over a connected and greeted Client (controller or observer); synchronous, like
// Client::request (call from your own thread, never from a Client callback).
//
// Errors carry the daemon's refusal as it came (code, field, sentence: NO_SUCH_RECORDING on
// `name`, REQUEST_OUT_OF_RANGE on `offset`/`max_length`/`last_s`, NOT_SUPPORTED when its recorder
// is off), or ErrorCode::kDriverError with field "connection" (no reply, lost connection) or "file"
// (the local file could not be read or written).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/client/client.hpp"
#include "ajar/core/result.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::client {

// Every recording of the daemon, newest first (several ListRecordings when there are more than 8).
Result<std::vector<protocol::RecordingInfo>> list_recordings(Client& client);

struct FetchProgress {
  std::uint64_t offset = 0;      // bytes of the file in the local copy now
  std::uint64_t size_bytes = 0;  // the recording's size on the daemon (grows while it is written)
  bool resumed = false;          // the local file already held `offset` bytes when fetch began
};
struct FetchOptions {
  std::uint16_t chunk_bytes = protocol::kMaxRecordingChunk;  // FetchRecording.max_length
  std::function<void(const FetchProgress&)> progress;  // after every chunk (and once at the start)
  // Tests only: stop (as if the connection broke) once this many bytes were written this call.
  std::uint64_t stop_after_bytes = 0;
};
// Fetches recording `name` into `path`. A `path` that exists is a partial copy: the fetch goes on
// from its size (resume), so an interrupted fetch run again gives the whole file. Ends when the
// daemon sends a chunk with no data (the end of the file, as far as it was written then). The
// result is the file's final size.
Result<std::uint64_t> fetch_recording(Client& client, std::string_view name,
                                      const std::string& path, const FetchOptions& options = {});

// Asks the daemon to keep the recordings overlapping the last `last_s` seconds (SaveRecording):
// the recordings saved, newest first.
Result<std::vector<protocol::RecordingInfo>> save_recording(Client& client, double last_s);

}  // namespace ajar::client
