// The Recordings of ajard (recordings.hpp) over its recorder (recorder.hpp): one reader thread of
// its own lists the directory and reads the chunks (bounded: kMaxJobs waiting, more are answered
// QUEUE_FULL at once); SaveRecording goes to the recorder thread (Recorder::save_last). Every
// answer is posted to the I/O thread.
#include <utility>

#include <sys/stat.h>

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>

#include "ajar/daemon/recordings.hpp"
#include "ajar/protocol/message_table.hpp"
#include "ajar/recorder/recorder.hpp"

namespace ajar::daemon {

namespace {

using protocol::MessageType;

protocol::RecordingInfo wire_info(const recorder::RecordingInfo& r) {
  protocol::RecordingInfo info;
  info.name.assign(r.name);
  info.size_bytes = r.bytes;
  info.start_unix_ns = static_cast<std::uint64_t>(std::max<std::int64_t>(r.start_unix_ns, 0));
  info.end_unix_ns = static_cast<std::uint64_t>(std::max<std::int64_t>(r.end_unix_ns, 0));
  info.writing = r.active;
  info.saved = r.saved;
  return info;
}

class RecorderRecordings final : public Recordings {
 public:
  static constexpr std::size_t kMaxJobs = 256;

  RecorderRecordings(recorder::Recorder& recorder, boost::asio::io_context& io)
      : recorder_(recorder), io_(io), thread_([this] { run(); }) {}
  ~RecorderRecordings() override {
    {
      std::lock_guard lock(queue_->mutex);
      queue_->stopping = true;
    }
    queue_->wake.notify_all();
    thread_.join();
  }

  void handle(const protocol::Message& request, Done done) override {
    if (!recorder_.settings().enabled) {
      answer(std::move(done),
             recordings_error(protocol::type_of(request), ErrorCode::kNotSupported, "",
                              "the recorder is off on this daemon (recorder.enabled: false)"));
      return;
    }
    if (auto refusal = check_recordings_request(request, kMaxSaveSeconds)) {
      answer(std::move(done), *refusal);
      return;
    }
    {
      std::lock_guard lock(queue_->mutex);
      if (queue_->jobs.size() < kMaxJobs) {
        queue_->jobs.push_back({request, std::move(done), std::nullopt});
        queue_->wake.notify_all();
        return;
      }
    }
    answer(std::move(done), recordings_error(protocol::type_of(request), ErrorCode::kQueueFull, "",
                                             "the recorder's reader is busy: ask again shortly"));
  }

 private:
  struct Job {
    protocol::Message request;
    Done done;
    std::optional<recorder::SaveResult> saved;  // the recorder's answer to a SaveRecording
  };
  // Shared with the recorder thread's save callbacks, which may come after this is destroyed.
  struct Queue {
    std::mutex mutex;
    std::condition_variable wake;
    std::deque<Job> jobs;
    bool stopping = false;
  };

  void answer(Done done, protocol::Message reply) {
    boost::asio::post(io_, [done = std::move(done), reply = std::move(reply)] { done(reply); });
  }

  std::vector<protocol::RecordingInfo> newest_first() const {
    std::vector<protocol::RecordingInfo> out;
    for (const auto& r : recorder_.list())
      out.push_back(wire_info(r));
    std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
      return a.start_unix_ns != b.start_unix_ns ? a.start_unix_ns > b.start_unix_ns
                                                : a.saved < b.saved;
    });
    return out;
  }

  protocol::Message fetch(const protocol::FetchRecording& f) const {
    const std::string name(f.name.view());
    struct stat st {};
    const auto path = std::filesystem::path(recorder_.settings().directory) / name;
    if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
      return recordings_error(
          MessageType::kFetchRecording, ErrorCode::kNoSuchRecording, protocol::refusal_field::kName,
          "no recording '" + name + "' (rotation may have removed it: list the recordings again)");
    }
    const auto size = static_cast<std::uint64_t>(st.st_size);
    if (f.offset > size) {
      return recordings_error(MessageType::kFetchRecording, ErrorCode::kRequestOutOfRange,
                              protocol::refusal_field::kOffset,
                              "offset " + std::to_string(f.offset) + " is beyond the end of '" +
                                  name + "' (" + std::to_string(size) + " bytes)");
    }
    std::string error;
    const auto bytes = recorder_.read(name, f.offset, f.max_length, &error);
    if (!bytes) {
      return recordings_error(MessageType::kFetchRecording, ErrorCode::kNoSuchRecording,
                              protocol::refusal_field::kName, error);
    }
    protocol::RecordingChunk chunk;
    chunk.offset = f.offset;
    chunk.size_bytes = std::max<std::uint64_t>(size, f.offset + bytes->size());
    chunk.data.assign(bytes->data(), bytes->size());
    return chunk;
  }

  void run() {
    for (;;) {
      Job job;
      {
        std::unique_lock lock(queue_->mutex);
        queue_->wake.wait(lock, [&] { return queue_->stopping || !queue_->jobs.empty(); });
        if (queue_->stopping) return;
        job = std::move(queue_->jobs.front());
        queue_->jobs.pop_front();
      }
      if (job.saved) {
        saved(std::move(job.done), std::move(*job.saved));
      } else if (const auto* list = std::get_if<protocol::ListRecordings>(&job.request)) {
        answer(std::move(job.done), recording_list(newest_first(), list->first));
      } else if (const auto* f = std::get_if<protocol::FetchRecording>(&job.request)) {
        answer(std::move(job.done), fetch(*f));
      } else if (const auto* save = std::get_if<protocol::SaveRecording>(&job.request)) {
        // Answered on the recorder thread: handed back to this one (never call the recorder from
        // inside its own callback).
        recorder_.save_last(static_cast<double>(save->last_s),
                            [queue = std::weak_ptr<Queue>(queue_), request = job.request,
                             done = std::move(job.done)](recorder::SaveResult r) mutable {
                              const auto q = queue.lock();
                              if (!q) return;
                              std::lock_guard lock(q->mutex);
                              if (q->stopping) return;
                              q->jobs.push_back({request, std::move(done), std::move(r)});
                              q->wake.notify_all();
                            });
      }
    }
  }

  // What the recorder saved, as the RecordingList of those files.
  void saved(Done done, recorder::SaveResult r) {
    if (!r.ok) {
      answer(std::move(done),
             recordings_error(MessageType::kSaveRecording, ErrorCode::kDriverError, "",
                              "the recordings could not be saved: " + r.error));
      return;
    }
    std::vector<protocol::RecordingInfo> kept;
    for (const auto& info : newest_first()) {
      if (std::find(r.names.begin(), r.names.end(), std::string(info.name.view())) != r.names.end())
        kept.push_back(info);
    }
    answer(std::move(done), recording_list(kept, 0));
  }

  recorder::Recorder& recorder_;
  boost::asio::io_context& io_;
  std::shared_ptr<Queue> queue_ = std::make_shared<Queue>();
  std::thread thread_;  // last: started once everything above is there
};

}  // namespace

std::unique_ptr<Recordings> make_recorder_recordings(recorder::Recorder& recorder,
                                                     boost::asio::io_context& io) {
  return std::make_unique<RecorderRecordings>(recorder, io);
}

}  // namespace ajar::daemon
