// Protocol 1.2, the black box (docs/protocol.md 5.23-5.27): a 1.1 session has none of it; the
// list pages; a fetch is a chunk of the file at its offset (a recording starts with the MCAP
// magic), refused naming the field when the name, offset or length is wrong; SaveRecording's
// range. A daemon whose recorder is off answers NOT_SUPPORTED: the checks that need a recording
// are skipped then.
#include "suite.hpp"

namespace ajar::conformance {

namespace {

constexpr std::array<std::uint8_t, 8> kMcapMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

protocol::FetchRecording fetch_of(std::string_view name, std::uint64_t offset,
                                  std::uint16_t max_length) {
  protocol::FetchRecording f;
  f.name.assign(name);
  f.offset = offset;
  f.max_length = max_length;
  return f;
}

// "" when Status.recorder says the recorder is off, as a NOT_SUPPORTED ListRecordings does.
std::string recorder_off_problem(const protocol::RecorderState& a) {
  if (a.enabled || a.mode != protocol::RecorderMode::kOff || a.file.length > 0)
    return std::string(
               "ListRecordings says the recorder is off; Status.recorder has "
               "enabled/mode/file ") +
           (a.enabled ? "true" : "false") + "/" + std::string(to_string(a.mode)) + "/" +
           std::string(a.file.view());
  return std::string{};
}

// "" when Status.recorder read before (`a`) and after (`b`) a listing is enabled, takes more than
// it drops, holds its open file in its directory, and no counter went down.
std::string recorder_counters_problem(const protocol::RecorderState& a,
                                      const protocol::RecorderState& b) {
  if (!a.enabled) return std::string("recordings listed; Status.recorder.enabled false");
  if (a.max_bytes == 0) return std::string("Status.recorder.max_bytes is 0");
  for (const auto* x : {&a, &b}) {
    if (x->loop_dropped > x->loop_samples || x->io_dropped > x->io_records)
      return std::string("more dropped than taken");
    if (x->directory_bytes < x->file_bytes)
      return std::string("directory_bytes below the open file's bytes");
  }
  if (b.loop_samples < a.loop_samples || b.io_records < a.io_records ||
      b.records_written < a.records_written || b.loop_dropped < a.loop_dropped ||
      b.io_dropped < a.io_dropped || b.records_lost < a.records_lost)
    return std::string("a Status.recorder counter went down");
  return std::string{};
}

// "" when the recording listed as being written is Status.recorder's file, its listed size
// between the file's bytes before and after; `rotated` when another file (a rotation between the
// reads may explain it: try again).
std::string written_file_problem(const protocol::RecordingList& list,
                                 const protocol::RecorderState& a, const protocol::RecorderState& b,
                                 bool& rotated) {
  const protocol::RecordingInfo* writing = nullptr;
  for (std::size_t i = 0; i < list.count; ++i) {
    if (list.entries[i].writing) writing = &list.entries[i];
  }
  if (writing == nullptr || writing->name.view() != a.file.view() ||
      a.file.view() != b.file.view()) {
    rotated = true;
    return "Status.recorder.file " + std::string(a.file.view()) +
           " is not the recording ListRecordings says is being written";
  }
  // The listed size is the file's on disk between the two Status reads.
  if (writing->size_bytes < a.file_bytes || writing->size_bytes > b.file_bytes)
    return "listed size " + std::to_string(writing->size_bytes) +
           " outside Status.recorder.file_bytes " + std::to_string(a.file_bytes) + ".." +
           std::to_string(b.file_bytes);
  return std::string{};
}

// "" when ListRecordings' reply `r` agrees with Status.recorder read before (`a`) and after (`b`).
std::string recorder_vs_list(const Response& r, const protocol::RecorderState& a,
                             const protocol::RecorderState& b, bool& rotated) {
  if (r.outcome == CallOutcome::kRefused && r.error.code == ErrorCode::kNotSupported) {
    return recorder_off_problem(a);
  }
  const auto* list = r.get<protocol::RecordingList>();
  if (!list) return "ListRecordings: " + describe(r);
  if (auto problem = recorder_counters_problem(a, b); !problem.empty()) return problem;
  if (a.mode != protocol::RecorderMode::kRecording) return std::string{};
  return written_file_problem(*list, a, b, rotated);
}

}  // namespace

std::string Suite::list_recordings_unknown_to_1_1() {
  auto c = open();
  if (!c) return std::string("cannot connect");
  protocol::Hello hello;
  hello.version_minor = 1;
  hello.requested_role = Role::kObserver;
  hello.client_name = "ajarctl conformance 1.1";
  std::uint32_t id = c->next_request_id();
  auto welcome = raw(*c, frame_bytes(protocol::Envelope{id, 0, hello}, 1), id);
  if (!welcome || !std::holds_alternative<protocol::Welcome>(welcome->message)) {
    return "Hello 1.1: " + describe(welcome);
  }
  id = c->next_request_id();
  auto reply = raw(*c, frame_bytes(protocol::Envelope{id, 0, protocol::ListRecordings{}}), id);
  if (auto e = want_error(reply, ErrorCode::kUnknownMessageType, "header.type", id); !e.empty())
    return e;
  return still_usable(*c);
}

std::string Suite::list_recordings_pages(std::optional<protocol::RecordingInfo>& newest,
                                         std::string& off) {
  auto c = greeted(Role::kObserver);
  if (!c) return std::string("cannot connect");
  if (c->welcome() && c->welcome()->version_minor < 2) {
    off = "the daemon speaks 1." + std::to_string(c->welcome()->version_minor);
    return skip(off);
  }
  const Response r = c->request(protocol::ListRecordings{0});
  if (r.outcome == CallOutcome::kRefused && r.error.code == ErrorCode::kNotSupported) {
    off = "the recorder is off: " + std::string(r.error.message.view());
    return skip(off);
  }
  const auto* list = r.get<protocol::RecordingList>();
  if (!list) return "ListRecordings: " + describe(r);
  if (list->first != 0) return "first is " + std::to_string(list->first) + ", asked 0";
  if (list->count > list->total || list->count > list->entries.size())
    return "count " + std::to_string(list->count) + " of " + std::to_string(list->total);
  for (std::size_t i = 1; i < list->count; ++i) {
    if (list->entries[i].start_unix_ns > list->entries[i - 1].start_unix_ns)
      return std::string("not newest first at entry ") + std::to_string(i);
  }
  if (list->count > 0) newest = list->entries[0];
  const Response past = c->request(protocol::ListRecordings{list->total});
  const auto* empty = past.get<protocol::RecordingList>();
  if (!empty || empty->count != 0) return "a list from `total` on: " + describe(past);
  return std::string{};
}

std::string Suite::recorder_status_agrees_with_list() {
  auto c = greeted(Role::kObserver);
  if (!c) return std::string("cannot connect");
  if (c->welcome() && c->welcome()->version_minor < 2) return skip("the daemon speaks 1.1");
  std::string wrong;
  // A rotation between the reads moves the file: three tries.
  for (int attempt = 0; attempt < 3; ++attempt) {
    const auto s1 = status(*c);
    const Response r = c->request(protocol::ListRecordings{0});
    const auto s2 = status(*c);
    if (!s1 || !s2) return std::string("GetStatus failed");
    bool rotated = false;
    wrong = recorder_vs_list(r, s1->recorder, s2->recorder, rotated);
    if (!rotated) return wrong;
  }
  return wrong;
}

std::string Suite::fetch_refuses_unknown_names() {
  auto c = greeted(Role::kObserver);
  if (!c) return std::string("cannot connect");
  for (const char* name : {"../ajard.state", "no-such-recording.mcap", "/etc/passwd"}) {
    if (auto e = want_error(c->request(fetch_of(name, 0, 16)), ErrorCode::kNoSuchRecording, "name");
        !e.empty())
      return std::string(name) + ": " + e;
  }
  return still_usable(*c);
}

std::string Suite::fetch_refuses_bad_lengths(const std::optional<protocol::RecordingInfo>& newest) {
  auto c = greeted(Role::kObserver);
  if (!c) return std::string("cannot connect");
  const std::string name = newest ? std::string(newest->name.view()) : "ajard-x.mcap";
  for (const std::uint16_t n :
       {std::uint16_t{0}, std::uint16_t{protocol::kMaxRecordingChunk + 1}}) {
    if (auto e = want_error(c->request(fetch_of(name, 0, n)), ErrorCode::kRequestOutOfRange,
                            "max_length");
        !e.empty())
      return "max_length " + std::to_string(n) + ": " + e;
  }
  return std::string{};
}

std::string Suite::fetch_starts_with_mcap_magic(const protocol::RecordingInfo& newest) {
  auto c = greeted(Role::kObserver);
  if (!c) return std::string("cannot connect");
  const Response r = c->request(fetch_of(newest.name.view(), 0, 16));
  const auto* chunk = r.get<protocol::RecordingChunk>();
  if (!chunk) return "FetchRecording: " + describe(r);
  if (chunk->offset != 0 || chunk->data.size() != 16)
    return "chunk at " + std::to_string(chunk->offset) + " with " +
           std::to_string(chunk->data.size()) + " bytes, asked 16 at 0";
  if (!std::equal(kMcapMagic.begin(), kMcapMagic.end(), chunk->data.data()))
    return std::string("the recording does not start with the MCAP magic");
  // Past the end: refused naming the offset; at the end: a chunk with no data.
  const std::uint64_t size = chunk->size_bytes;
  if (auto e = want_error(c->request(fetch_of(newest.name.view(), size + 1, 16)),
                          ErrorCode::kRequestOutOfRange, "offset");
      !e.empty() && !newest.writing)
    return "offset size + 1: " + e;
  return std::string{};
}

std::string Suite::save_refuses_bad_ranges() {
  auto c = greeted(Role::kObserver);
  if (!c) return std::string("cannot connect");
  for (const float s : {0.0f, -1.0f}) {
    if (auto e = want_error(c->request(protocol::SaveRecording{s}), ErrorCode::kRequestOutOfRange,
                            "last_s");
        !e.empty())
      return "last_s " + std::to_string(s) + ": " + e;
  }
  return still_usable(*c);
}

void Suite::recordings() {
  // The newest recording, once listed (empty: none, or the recorder is off).
  std::optional<protocol::RecordingInfo> newest;
  std::string off;  // why the recording checks are skipped
  check("1.2: a 1.1 session gets UNKNOWN_MESSAGE_TYPE for ListRecordings",
        [&] { return list_recordings_unknown_to_1_1(); });
  check("1.2: ListRecordings (observer) pages the recordings, newest first",
        [&] { return list_recordings_pages(newest, off); });
  check("1.2: Status.recorder agrees with ListRecordings (mode, the file being written, counts)",
        [&] { return recorder_status_agrees_with_list(); });
  check("1.2: FetchRecording of a name that is no recording: NO_SUCH_RECORDING (name)",
        [&] { return off.empty() ? fetch_refuses_unknown_names() : skip(off); });
  check("1.2: FetchRecording max_length 0 or 961: REQUEST_OUT_OF_RANGE (max_length)",
        [&] { return off.empty() ? fetch_refuses_bad_lengths(newest) : skip(off); });
  check("1.2: FetchRecording from offset 0 is the file's start (the MCAP magic)", [&] {
    if (!off.empty()) return skip(off);
    if (!newest) return skip("the daemon has no recording yet");
    return fetch_starts_with_mcap_magic(*newest);
  });
  check("1.2: SaveRecording of 0 or -1 s: REQUEST_OUT_OF_RANGE (last_s)",
        [&] { return off.empty() ? save_refuses_bad_ranges() : skip(off); });
}

}  // namespace ajar::conformance
