#include "ajar/client/blackbox.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include <sys/stat.h>

namespace ajar::client {

namespace {

Error from_response(const Response& r, std::string_view what) {
  if (r.outcome == CallOutcome::kRefused) {
    return Error{r.error.code, std::string(r.error.field.view()),
                 std::string(r.error.message.view())};
  }
  if (r.ok()) {
    return make_error(ErrorCode::kInternal, "", std::string(what) + ": unexpected reply");
  }
  return make_error(ErrorCode::kDriverError, "connection",
                    std::string(what) + ": " + std::string(to_string(r.outcome)) +
                        (r.transport_error.empty() ? "" : ": " + r.transport_error));
}

std::vector<protocol::RecordingInfo> entries_of(const protocol::RecordingList& list) {
  return {list.entries.begin(),
          list.entries.begin() + std::min<std::size_t>(list.count, list.entries.size())};
}

}  // namespace

Result<std::vector<protocol::RecordingInfo>> list_recordings(Client& client) {
  std::vector<protocol::RecordingInfo> all;
  for (std::uint32_t first = 0;;) {
    const Response r = client.request(protocol::ListRecordings{first});
    const auto* list = r.get<protocol::RecordingList>();
    if (list == nullptr) return from_response(r, "ListRecordings");
    for (const auto& e : entries_of(*list))
      all.push_back(e);
    first += list->count;
    if (list->count == 0 || first >= list->total) break;
  }
  return all;
}

Result<std::uint64_t> fetch_recording(Client& client, std::string_view name,
                                      const std::string& path, const FetchOptions& options) {
  std::uint64_t offset = 0;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) offset = static_cast<std::uint64_t>(st.st_size);
  const bool resumed = offset > 0;
  std::ofstream out(path, std::ios::binary | std::ios::app);
  if (!out) {
    return make_error(ErrorCode::kDriverError, "file",
                      "cannot write " + path + ": " + std::strerror(errno));
  }
  protocol::FetchRecording request;
  request.name.assign(name);
  request.max_length = options.chunk_bytes;
  std::uint64_t written = 0;
  bool first = true;
  for (;;) {
    request.offset = offset;
    const Response r = client.request(request);
    const auto* chunk = r.get<protocol::RecordingChunk>();
    if (chunk == nullptr) {
      Error e = from_response(r, "FetchRecording");
      if (e.field == "offset" && resumed) {
        e.message += " (" + path + " already holds " + std::to_string(offset) +
                     " bytes: is it a copy of another recording?)";
      }
      return e;
    }
    if (chunk->offset != offset) {
      return make_error(ErrorCode::kInternal, "offset",
                        "the daemon answered a chunk at " + std::to_string(chunk->offset) +
                            " for offset " + std::to_string(offset));
    }
    if (first && options.progress) options.progress({offset, chunk->size_bytes, resumed});
    first = false;
    if (chunk->data.size() == 0) break;
    out.write(reinterpret_cast<const char*>(chunk->data.data()),
              static_cast<std::streamsize>(chunk->data.size()));
    out.flush();
    if (!out) {
      return make_error(ErrorCode::kDriverError, "file",
                        "cannot write " + path + ": " + std::strerror(errno));
    }
    offset += chunk->data.size();
    written += chunk->data.size();
    if (options.progress) options.progress({offset, chunk->size_bytes, resumed});
    if (options.stop_after_bytes != 0 && written >= options.stop_after_bytes) {
      return make_error(ErrorCode::kDriverError, "connection",
                        "stopped after " + std::to_string(written) + " bytes (test)");
    }
  }
  return offset;
}

Result<std::vector<protocol::RecordingInfo>> save_recording(Client& client, double last_s) {
  const Response r =
      client.request(protocol::SaveRecording{static_cast<float>(last_s)}, Milliseconds{10000}, 0);
  const auto* list = r.get<protocol::RecordingList>();
  if (list == nullptr) return from_response(r, "SaveRecording");
  return entries_of(*list);
}

}  // namespace ajar::client
