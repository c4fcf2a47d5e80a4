#include "ajar/daemon/recordings.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ajar/protocol/message_table.hpp"

namespace ajar::daemon {

using protocol::MessageType;
namespace rf = protocol::refusal_field;

protocol::ErrorReply recordings_error(MessageType type, ErrorCode code, std::string_view field,
                                      std::string_view message) {
  protocol::ErrorReply e;
  e.code = code;
  e.offending_type = type;
  e.field = field;
  e.message = message;
  return e;
}

bool is_recording_name(std::string_view name) noexcept {
  if (name.starts_with("saved/")) name.remove_prefix(6);
  return !name.empty() && name.find('/') == std::string_view::npos && name != "." && name != ".." &&
         !name.starts_with('.') && name.ends_with(".mcap");
}

std::optional<protocol::ErrorReply> check_recordings_request(const protocol::Message& request,
                                                             double max_save_s) {
  if (const auto* fetch = std::get_if<protocol::FetchRecording>(&request)) {
    if (!is_recording_name(fetch->name.view())) {
      std::string why(fetch->name.view());
      why.append(
          " is not a recording name (ListRecordings gives them: NAME.mcap or "
          "saved/NAME.mcap)");
      return recordings_error(MessageType::kFetchRecording, ErrorCode::kNoSuchRecording, rf::kName,
                              why);
    }
    if (fetch->max_length == 0 || fetch->max_length > protocol::kMaxRecordingChunk) {
      char text[80];
      std::snprintf(text, sizeof text, "max_length is %u: allowed 1..%zu",
                    static_cast<unsigned>(fetch->max_length), protocol::kMaxRecordingChunk);
      return recordings_error(MessageType::kFetchRecording, ErrorCode::kRequestOutOfRange,
                              rf::kMaxLength, text);
    }
  } else if (const auto* save = std::get_if<protocol::SaveRecording>(&request)) {
    const double s = static_cast<double>(save->last_s);
    if (!(s > 0) || s > max_save_s) {
      char text[160];
      std::snprintf(text, sizeof text, "last_s is %g: allowed above 0 up to %g s", s, max_save_s);
      return recordings_error(MessageType::kSaveRecording, ErrorCode::kRequestOutOfRange,
                              rf::kLastS, text);
    }
  }
  return std::nullopt;
}

protocol::RecordingList recording_list(const std::vector<protocol::RecordingInfo>& newest_first,
                                       std::uint32_t first) {
  protocol::RecordingList list;
  list.total = static_cast<std::uint32_t>(newest_first.size());
  list.first = first;
  for (std::size_t i = first; i < newest_first.size() && list.count < list.entries.size(); ++i)
    list.entries[list.count++] = newest_first[i];
  return list;
}

}  // namespace ajar::daemon
