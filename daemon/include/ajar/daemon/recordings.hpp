// Recordings: what the session hub asks of the recorder for protocol 1.2
// (docs/protocol.md 5.23-5.27, docs/blackbox.md): ListRecordings, FetchRecording, SaveRecording.
//
// handle() returns at once: the work (listing the directory, reading a file, the save) runs on
// another thread, never on the I/O thread, so a slow or hung disk delays only the black box's own
// replies. `done` is called exactly once with the reply (RecordingList, RecordingChunk or an
// ErrorReply naming the field), on the I/O thread (the implementation posts it there), unless the
// black box is stopped first; then it is never called. The hub keeps the session's replies in
// request order around it (session_hub.hpp).
//
// check_recordings_request() is the part of the validation that needs no disk (max_length, last_s,
// the shape of a name): the same answer on every implementation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/protocol/messages.hpp"

namespace boost::asio {
class io_context;
}
namespace ajar::recorder {
class Recorder;
}

namespace ajar::daemon {

// The longest SaveRecording.last_s (a day): more is REQUEST_OUT_OF_RANGE.
inline constexpr double kMaxSaveSeconds = 86400;

class Recordings {
 public:
  using Done = std::function<void(protocol::Message reply)>;
  virtual ~Recordings() = default;
  // `request` is a ListRecordings, FetchRecording or SaveRecording.
  virtual void handle(const protocol::Message& request, Done done) = 0;
};

// The refusal of a request that is wrong whatever the disk holds, or nullopt. `max_save_s`: the
// longest SaveRecording.last_s (kMaxSaveSeconds in ajard).
std::optional<protocol::ErrorReply> check_recordings_request(const protocol::Message& request,
                                                             double max_save_s);
// A name ListRecordings can give: "NAME.mcap" or "saved/NAME.mcap", NAME without '/', not ".."
bool is_recording_name(std::string_view name) noexcept;

// The RecordingList reply for entries [first, first + 8) of `newest_first`.
protocol::RecordingList recording_list(const std::vector<protocol::RecordingInfo>& newest_first,
                                       std::uint32_t first);

// ajard's Recordings over its recorder (recorder_recordings.cpp): a reader thread of its own lists
// and reads (at most 256 requests waiting; more are answered QUEUE_FULL), SaveRecording goes to
// the recorder thread; answers are posted to `io`. NOT_SUPPORTED while the recorder is disabled.
// Destroy it before `recorder`; answers not posted by then are never given.
std::unique_ptr<Recordings> make_recorder_recordings(recorder::Recorder& recorder,
                                                     boost::asio::io_context& io);

protocol::ErrorReply recordings_error(protocol::MessageType type, ErrorCode code,
                                      std::string_view field, std::string_view message);

}  // namespace ajar::daemon
