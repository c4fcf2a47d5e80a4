// The session hub's side of the black box (protocol 1.2; session_hub.hpp): any greeted session may
// ask, the answer comes from another thread and keeps its place among the session's replies, a
// black box that does not answer never holds a Stop (its Ack waits at most kHeldReplyLimit), and
// the checks that need no disk (recordings.hpp).
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>

#include <boost/asio/post.hpp>
#include <gtest/gtest.h>

#include "ajar/daemon/recordings.hpp"
#include "ajar/recorder/channels.hpp"
#include "ajar/recorder/recorder.hpp"
#include "test_client.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {
namespace {

using protocol::MessageType;
using protocol::Role;
using namespace std::chrono_literals;

// Keeps every request until the test answers it; answers on the I/O thread, as the real one does.
class FakeRecordings final : public daemon::Recordings {
 public:
  void handle(const protocol::Message& request, Done done) override {
    std::lock_guard lock(mutex_);
    pending_.push_back({request, std::move(done)});
    changed_.notify_all();
  }
  // Waits until `n` requests were handed over (generous bound).
  bool wait_for(std::size_t n) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, 20s, [&] { return handed_ + pending_.size() >= n; });
  }
  protocol::Message oldest() {
    std::lock_guard lock(mutex_);
    return pending_.front().request;
  }
  void answer_oldest(protocol::Message reply) {
    Pending p;
    {
      std::lock_guard lock(mutex_);
      p = std::move(pending_.front());
      pending_.pop_front();
      ++handed_;
    }
    boost::asio::post(*io, [done = std::move(p.done), reply = std::move(reply)] { done(reply); });
  }
  boost::asio::io_context* io = nullptr;

 private:
  struct Pending {
    protocol::Message request;
    Done done;
  };
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Pending> pending_;
  std::size_t handed_ = 0;
};

// The next reply of the session, whatever its request id (events and telemetry skipped).
protocol::Envelope next_reply(TestClient& c) {
  for (;;) {
    auto outcome = c.next(20s);
    if (!outcome) {
      ADD_FAILURE() << "no reply";
      return {};
    }
    if (outcome->kind != protocol::StreamDecoder::Kind::kMessage) continue;
    const auto type = protocol::type_of(outcome->envelope.message);
    if (type == MessageType::kEvent || type == MessageType::kTelemetry) continue;
    return outcome->envelope;
  }
}

protocol::RecordingChunk chunk_of(std::uint64_t offset, std::size_t n) {
  protocol::RecordingChunk chunk;
  chunk.offset = offset;
  chunk.size_bytes = offset + n;
  std::vector<std::uint8_t> data(n, 0x5A);
  chunk.data.assign(data.data(), data.size());
  return chunk;
}

class RecordingsHub : public ::testing::Test {
 protected:
  void SetUp() override { box_.io = &server_.io(); }
  static daemon::ServerOptions options(daemon::Recordings* box) {
    daemon::ServerOptions o;
    o.max_clients = 16;
    o.recordings = box;
    return o;
  }
  FakeEngine engine_;
  FakeRecordings box_;
  ServerThread server_{engine_, options(&box_)};
};

TEST_F(RecordingsHub, AnObserverFetchesAndItsRepliesKeepRequestOrder) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  protocol::FetchRecording fetch;
  fetch.name = "ajard-20261126T130000000Z.mcap";
  fetch.offset = 960;
  const auto fetch_id = c.send(fetch);
  const auto ping_id = c.send(protocol::Ping{7});
  ASSERT_TRUE(box_.wait_for(1));
  const auto asked = std::get<protocol::FetchRecording>(box_.oldest());
  EXPECT_EQ(asked.name.view(), fetch.name.view());
  EXPECT_EQ(asked.offset, 960U);
  box_.answer_oldest(chunk_of(960, 100));
  // The Ping was answered at once by the hub, but its Pong waited behind the chunk.
  const auto first = next_reply(c);
  EXPECT_EQ(first.request_id, fetch_id);
  ASSERT_TRUE(std::holds_alternative<protocol::RecordingChunk>(first.message));
  EXPECT_EQ(std::get<protocol::RecordingChunk>(first.message).data.size(), 100U);
  const auto second = next_reply(c);
  EXPECT_EQ(second.request_id, ping_id);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(second.message));
}

TEST_F(RecordingsHub, ASilentBlackBoxNeverHoldsAStop) {
  TestClient c(server_.port());
  c.hello(Role::kController);
  const auto list_id = c.send(protocol::ListRecordings{});
  const auto stop_id = c.send(protocol::Stop{});
  ASSERT_TRUE(box_.wait_for(1));
  // The Stop reached the engine while the black box had not answered.
  for (int i = 0; i < 2000 && engine_.count(MessageType::kStop) == 0; ++i)
    std::this_thread::sleep_for(10ms);
  EXPECT_EQ(engine_.count(MessageType::kStop), 1U);
  // Its Ack comes once the black box's request was given up (kHeldReplyLimit), right after it.
  const auto first = next_reply(c);
  EXPECT_EQ(first.request_id, list_id);
  ASSERT_TRUE(std::holds_alternative<protocol::ErrorReply>(first.message));
  EXPECT_EQ(std::get<protocol::ErrorReply>(first.message).code, ErrorCode::kDriverError);
  EXPECT_EQ(std::get<protocol::ErrorReply>(first.message).offending_type,
            MessageType::kListRecordings);
  const auto second = next_reply(c);
  EXPECT_EQ(second.request_id, stop_id);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(second.message));
  // The late answer is dropped: the next reply is the next request's.
  box_.answer_oldest(protocol::RecordingList{});
  const auto ping_id = c.send(protocol::Ping{1});
  EXPECT_EQ(next_reply(c).request_id, ping_id);
}

TEST_F(RecordingsHub, OneSessionHasABoundedNumberOfRequestsOutstanding) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  for (std::size_t i = 0; i < daemon::SessionHub::kMaxRecordingsPending; ++i)
    c.send(protocol::ListRecordings{});
  const auto refused = c.send(protocol::ListRecordings{});
  ASSERT_TRUE(box_.wait_for(daemon::SessionHub::kMaxRecordingsPending));
  for (std::size_t i = 0; i < daemon::SessionHub::kMaxRecordingsPending; ++i)
    box_.answer_oldest(protocol::RecordingList{});
  for (std::size_t i = 0; i < daemon::SessionHub::kMaxRecordingsPending; ++i)
    EXPECT_TRUE(std::holds_alternative<protocol::RecordingList>(next_reply(c).message));
  const auto last = next_reply(c);
  EXPECT_EQ(last.request_id, refused);
  ASSERT_TRUE(std::holds_alternative<protocol::ErrorReply>(last.message));
  EXPECT_EQ(std::get<protocol::ErrorReply>(last.message).code, ErrorCode::kQueueFull);
}

TEST(RecordingsOff, EveryBlackBoxRequestIsNotSupported) {
  FakeEngine engine;
  ServerThread server(engine, daemon::ServerOptions{});
  TestClient c(server.port());
  c.hello(Role::kObserver);
  for (protocol::Message m : {protocol::Message{protocol::ListRecordings{}},
                              protocol::Message{protocol::FetchRecording{}},
                              protocol::Message{protocol::SaveRecording{60}}}) {
    const auto reply = c.request(m);
    ASSERT_EQ(error_code_of(reply), ErrorCode::kNotSupported)
        << protocol::to_string(protocol::type_of(m));
    EXPECT_EQ(std::get<protocol::ErrorReply>(reply).offending_type, protocol::type_of(m));
  }
  EXPECT_EQ(error_code_of(TestClient(server.port()).request(protocol::ListRecordings{})),
            ErrorCode::kHelloRequired);
}

TEST(RecordingsChecks, RequestsWrongWhateverTheDiskHoldsNameTheirField) {
  const auto field = [](const protocol::Message& m) {
    const auto e = daemon::check_recordings_request(m, 600);
    return e ? std::string(to_string(e->code)) + " " + std::string(e->field.view()) : "ok";
  };
  protocol::FetchRecording fetch;
  fetch.name = "ajard-20261126T130000000Z.mcap";
  EXPECT_EQ(field(fetch), "ok");
  fetch.name = "saved/ajard-20261126T130000000Z.mcap";
  EXPECT_EQ(field(fetch), "ok");
  for (const char* bad : {"", "../ajard.state", "saved/../x.mcap", "/etc/passwd", "a/b.mcap",
                          ".hidden.mcap", "ajard.state", "saved/"}) {
    fetch.name = bad;
    EXPECT_EQ(field(fetch), "NO_SUCH_RECORDING name") << bad;
  }
  fetch.name = "ajard-20261126T130000000Z.mcap";
  fetch.max_length = 0;
  EXPECT_EQ(field(fetch), "REQUEST_OUT_OF_RANGE max_length");
  fetch.max_length = protocol::kMaxRecordingChunk + 1;
  EXPECT_EQ(field(fetch), "REQUEST_OUT_OF_RANGE max_length");
  fetch.max_length = 1;
  EXPECT_EQ(field(fetch), "ok");
  EXPECT_EQ(field(protocol::SaveRecording{0}), "REQUEST_OUT_OF_RANGE last_s");
  EXPECT_EQ(field(protocol::SaveRecording{-5}), "REQUEST_OUT_OF_RANGE last_s");
  EXPECT_EQ(field(protocol::SaveRecording{601}), "REQUEST_OUT_OF_RANGE last_s");
  EXPECT_EQ(field(protocol::SaveRecording{300}), "ok");
  EXPECT_EQ(field(protocol::ListRecordings{}), "ok");
}

TEST(RecordingsChecks, RecordingListPagesNewestFirst) {
  std::vector<protocol::RecordingInfo> all(11);
  for (std::size_t i = 0; i < all.size(); ++i)
    all[i].size_bytes = i;
  const auto page = daemon::recording_list(all, 8);
  EXPECT_EQ(page.total, 11U);
  EXPECT_EQ(page.first, 8U);
  ASSERT_EQ(page.count, 3U);
  EXPECT_EQ(page.entries[0].size_bytes, 8U);
  EXPECT_EQ(page.entries[2].size_bytes, 10U);
  EXPECT_EQ(page.entries[3].size_bytes, 0U);
  EXPECT_EQ(daemon::recording_list(all, 11).count, 0U);
  EXPECT_EQ(daemon::recording_list(all, 0).count, 8U);
}

// ajard's Recordings over a real recorder on a temporary directory (recorder_recordings.cpp): the
// list is newest first with the writing file marked, a chunk is the file's bytes at the offset, a
// fetch past the end or of a name that is no recording is refused naming the field, and a save
// answers with the recordings it kept.
namespace adapter {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    char tmpl[] = "/tmp/ajar-recordings-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

// Asks `recordings` and runs `io` until the answer came (generous bound).
protocol::Message ask(daemon::Recordings& recordings, boost::asio::io_context& io,
                      const protocol::Message& request) {
  std::optional<protocol::Message> answer;
  recordings.handle(request, [&](protocol::Message m) { answer = std::move(m); });
  io.restart();
  const auto until = std::chrono::steady_clock::now() + 20s;
  while (!answer && std::chrono::steady_clock::now() < until) {
    io.run_for(10ms);
    io.restart();
  }
  EXPECT_TRUE(answer.has_value()) << "no answer";
  return answer.value_or(protocol::ErrorReply{});
}

TEST(RecorderRecordings, ListFetchAndSaveARealRecording) {
  TempDir dir;
  recorder::RecorderSettings settings;
  settings.directory = dir.path.string();
  recorder::Recorder rec(settings, [](std::string_view) {});
  rec.start();
  const std::vector<std::uint8_t> frame(100, 0x42);
  for (std::uint64_t i = 0; i < 50; ++i)
    rec.frame(recorder::kWireIn, 1, i * 1000, frame);
  boost::asio::io_context io;
  const auto recordings = daemon::make_recorder_recordings(rec, io);

  // The writing file, listed once the recorder thread opened it (start() does not wait for the
  // disk); its bytes grow once the recorder thread wrote the frames.
  protocol::RecordingInfo info;
  const auto until = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < until) {
    const auto list =
        std::get<protocol::RecordingList>(ask(*recordings, io, protocol::ListRecordings{}));
    ASSERT_LE(list.total, 1U);
    if (list.total == 1) {
      info = list.entries[0];
      if (info.size_bytes > 50 * frame.size()) break;
    }
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_TRUE(info.writing);
  EXPECT_FALSE(info.saved);
  ASSERT_GT(info.size_bytes, 50 * frame.size());

  protocol::FetchRecording fetch;
  fetch.name = info.name;
  fetch.offset = 0;
  fetch.max_length = 8;
  const auto chunk = std::get<protocol::RecordingChunk>(ask(*recordings, io, fetch));
  ASSERT_EQ(chunk.data.size(), 8U);
  EXPECT_EQ(chunk.data.data()[0], 0x89);
  EXPECT_EQ(chunk.data.data()[1], 'M');
  EXPECT_GE(chunk.size_bytes, info.size_bytes);
  fetch.offset = chunk.size_bytes + 1000000;
  const auto past = ask(*recordings, io, fetch);
  ASSERT_EQ(error_code_of(past), ErrorCode::kRequestOutOfRange);
  EXPECT_EQ(std::get<protocol::ErrorReply>(past).field.view(), "offset");
  fetch.offset = 0;
  fetch.name = "ajard-19700101T000000000Z.mcap";
  const auto missing = ask(*recordings, io, fetch);
  ASSERT_EQ(error_code_of(missing), ErrorCode::kNoSuchRecording);
  EXPECT_EQ(std::get<protocol::ErrorReply>(missing).field.view(), "name");
  fetch.name = "../x.mcap";
  EXPECT_EQ(std::get<protocol::ErrorReply>(ask(*recordings, io, fetch)).field.view(), "name");

  const auto saved = ask(*recordings, io, protocol::SaveRecording{60});
  ASSERT_TRUE(std::holds_alternative<protocol::RecordingList>(saved))
      << std::get<protocol::ErrorReply>(saved).message.view();
  const auto& kept = std::get<protocol::RecordingList>(saved);
  ASSERT_GE(kept.count, 1U);
  EXPECT_TRUE(kept.entries[0].saved);
  EXPECT_TRUE(kept.entries[0].name.view().starts_with("saved/"));
  fetch.name = kept.entries[0].name;
  fetch.max_length = 8;
  EXPECT_EQ(std::get<protocol::RecordingChunk>(ask(*recordings, io, fetch)).data.size(), 8U);
  rec.stop();
}

}  // namespace adapter

}  // namespace
}  // namespace ajar::test
