// Golden vectors: each is checked against this client's codec and sent to the daemon.
#include "suite.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace ajar::conformance {

// ---- golden vectors ----
void Suite::golden_vectors() {
  namespace fs = std::filesystem;
  std::vector<fs::path> files;
  std::error_code ec;
  if (fs::is_directory(options_.vectors_dir, ec)) {
    for (const auto& entry : fs::directory_iterator(options_.vectors_dir, ec)) {
      if (entry.path().extension() == ".vec") files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  check("vectors: found in " + options_.vectors_dir, [&] {
    return files.empty() ? std::string("no *.vec files (use --vectors DIR)") : std::string{};
  });
  for (const auto& path : files) {
    std::ifstream f(path);
    std::stringstream text;
    text << f.rdbuf();
    auto parsed = protocol::parse_vector(text.str());
    const std::string name = "vector " + path.stem().string();
    if (!parsed) {
      check(name + ": parse", [&] { return parsed.error().message; });
      continue;
    }
    const protocol::GoldenVector& v = *parsed;
    check(name + ": this client's codec", [&] {
      auto s = protocol::check_vector(v);
      return s ? std::string{} : s.error().message;
    });
    if (v.direction == protocol::GoldenVector::Direction::kHostToDaemon) {
      check(name + ": daemon", [&] { return send_vector(v); });
    }
  }
}

namespace {

// "" when `reply` is what an observer gets for a valid request of `type` (not Hello;
// a reply came).
std::string observer_reply_problem(MessageType type,
                                   const std::optional<protocol::Envelope>& reply) {
  const auto* err = std::get_if<protocol::ErrorReply>(&reply->message);
  switch (type) {
    case MessageType::kPing:
      if (!std::holds_alternative<protocol::Pong>(reply->message)) return "got " + describe(reply);
      break;
    case MessageType::kGetStatus:
      if (!std::holds_alternative<protocol::Status>(reply->message)) {
        return "got " + describe(reply);
      }
      break;
    case MessageType::kGetRobotModel:
      if (!std::holds_alternative<protocol::RobotModel>(reply->message)) {
        return "got " + describe(reply);
      }
      break;
    case MessageType::kSubscribe:
    case MessageType::kStop:
    case MessageType::kEmergencyStop:
      if (!std::holds_alternative<protocol::Ack>(reply->message)) return "got " + describe(reply);
      break;
    case MessageType::kListRecordings:
    case MessageType::kFetchRecording:
    case MessageType::kSaveRecording:
      // 1.2, any greeted session: answered (RecordingList / RecordingChunk), or refused for
      // what the daemon has (its recorder off, no such recording), never by the decoder.
      if (err == nullptr
              ? !std::holds_alternative<protocol::RecordingList>(reply->message) &&
                    !std::holds_alternative<protocol::RecordingChunk>(reply->message)
              : err->code != ErrorCode::kNotSupported && err->code != ErrorCode::kNoSuchRecording) {
        return "got " + describe(reply);
      }
      break;
    default:  // commands: decoded, then refused by the session rules (observer)
      if (!err || err->code != ErrorCode::kNotController) {
        return "expected Error NOT_CONTROLLER (decoded, observer), got " + describe(reply);
      }
  }
  return {};
}

}  // namespace

std::string Suite::send_hello_vector(const protocol::GoldenVector& v, std::uint32_t request_id) {
  // As the first frame of a fresh session; no controller holds control at this point.
  auto c = open();
  if (!c) return "cannot connect";
  auto reply = raw(*c, v.bytes, request_id);
  if (!reply || !std::holds_alternative<protocol::Welcome>(reply->message)) {
    return "expected Welcome with request id " + std::to_string(request_id) + ", got " +
           describe(reply);
  }
  return {};
}

std::string Suite::send_valid_vector(Client& c, const protocol::GoldenVector& v,
                                     std::uint32_t request_id, MessageType type) {
  auto reply = raw(c, v.bytes, request_id);
  if (!reply) return "no reply with request id " + std::to_string(request_id);
  if (auto problem = observer_reply_problem(type, reply); !problem.empty()) return problem;
  if (type == MessageType::kEmergencyStop) {
    auto ctl = greeted(Role::kController, true);
    if (!ctl || !ctl->request(protocol::Reset{false}).ok()) return "cannot Reset after it";
  }
  if (type == MessageType::kSubscribe) (void)c.request(protocol::Subscribe{});
  return still_usable(c);
}

std::string Suite::send_invalid_vector(Client& c, const protocol::GoldenVector& v,
                                       std::uint32_t request_id) {
  const std::string code(ajar::to_string(v.expected_error));
  auto reply = raw(c, v.bytes, std::nullopt);
  const auto* err = reply ? std::get_if<protocol::ErrorReply>(&reply->message) : nullptr;
  if (!err || err->code != v.expected_error)
    return "expected Error " + code + ", got " + describe(reply);
  if (!v.field.empty() && err->field.view() != v.field) {
    return "expected field '" + v.field + "', got '" + std::string(err->field.view()) + "'";
  }
  if (v.framing_lost) {
    if (!c.wait_closed(timeout())) return "connection not closed after framing was lost";
    return {};
  }
  if (v.expected_error != ErrorCode::kCrcMismatch && reply->request_id != request_id) {
    return "reply request id " + std::to_string(reply->request_id) + ", expected " +
           std::to_string(request_id);
  }
  return still_usable(c);
}

std::string Suite::send_vector(const protocol::GoldenVector& v) {
  std::array<std::uint8_t, protocol::kHeaderSize> header{};
  std::copy_n(v.bytes.begin(), std::min(v.bytes.size(), header.size()), header.begin());
  const protocol::FrameHeader h = protocol::decode_header(header);
  const auto type = static_cast<MessageType>(h.type);
  if (v.expect_ok && type == MessageType::kHello) return send_hello_vector(v, h.request_id);
  auto c = greeted(Role::kObserver);
  if (!c) return "cannot open an observer session";
  if (v.expect_ok) return send_valid_vector(*c, v, h.request_id, type);
  return send_invalid_vector(*c, v, h.request_id);
}

}  // namespace ajar::conformance
