// ajarctl blackbox: list, fetch and save over the protocol (ajar/client/blackbox.hpp); show and
// export read a recording (ajar/recorder/mcap_reader.hpp) with the channels of
// ajar/recorder/channels.hpp.
#include "blackbox_cmd.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "ajar/client/blackbox.hpp"
#include "ajar/client/output.hpp"
#include "ajar/recorder/channels.hpp"
#include "session.hpp"

namespace ajar::client {

namespace {

using ordered_json = nlohmann::ordered_json;

int usage(std::ostream& err, const std::string& message) {
  err << "ajarctl: blackbox: " << message
      << " (usage: blackbox list | fetch NAME [-o FILE] | save SECONDS | show FILE [--all] | "
         "export FILE --csv [-o FILE])\n";
  return kExitUsage;
}

int refused(std::ostream& err, std::string_view what, const Error& e) {
  err << "ajarctl: " << what << ": " << to_string(e.code);
  if (!e.field.empty()) err << " (" << e.field << ")";
  err << ": " << e.message << "\n";
  return e.field == "connection" ? kExitConnection : kExitRefused;
}

std::string utc(std::uint64_t unix_ns) {
  const auto seconds = static_cast<std::time_t>(unix_ns / 1000000000ULL);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S", &tm);
  return std::string(text) + "Z";
}

// Connects and says Hello as an observer (the black box needs no control).
std::optional<int> connect(Client& client, const GlobalOptions& options, std::ostream& err) {
  if (const auto c = client.connect(options.endpoint); !c) {
    err << "ajarctl: connect: " << c.error().message << "\n";
    return kExitConnection;
  }
  const Response r = client.hello(protocol::Role::kObserver);
  if (!r.ok()) {
    err << "ajarctl: hello: "
        << (r.outcome == CallOutcome::kRefused ? std::string(r.error.message.view())
                                               : r.transport_error)
        << "\n";
    return exit_code(r);
  }
  const auto welcome = client.welcome();
  if (welcome && welcome->version_minor < 2) {
    err << "ajarctl: blackbox: the daemon speaks protocol 1." << int{welcome->version_minor}
        << ": recordings need 1.2\n";
    return kExitRefused;
  }
  return std::nullopt;
}

ClientOptions client_options(const GlobalOptions& o) {
  ClientOptions c;
  c.request_timeout = Milliseconds(static_cast<long>(std::lround(o.timeout_s * 1000)));
  c.connect_timeout = std::max(c.request_timeout, Milliseconds{1000});
  c.retries = o.retries;
  c.client_name = "ajarctl blackbox";
  c.tls = o.tls;
  return c;
}

void print_recordings(const std::vector<protocol::RecordingInfo>& list, const GlobalOptions& o,
                      std::ostream& out) {
  if (o.json) {
    for (const auto& r : list) {
      out << ordered_json{{"type", "recording"},
                          {"name", std::string(r.name.view())},
                          {"size_bytes", r.size_bytes},
                          {"start_unix_ns", r.start_unix_ns},
                          {"end_unix_ns", r.end_unix_ns},
                          {"writing", r.writing},
                          {"saved", r.saved}}
                 .dump()
          << "\n";
    }
    return;
  }
  if (list.empty()) {
    out << "no recordings\n";
    return;
  }
  for (const auto& r : list) {
    char line[256];
    std::snprintf(line, sizeof line, "%-44s %10s  %s .. %s%s%s\n",
                  std::string(r.name.view()).c_str(), bytes_text(r.size_bytes).c_str(),
                  utc(r.start_unix_ns).c_str(), utc(r.end_unix_ns).c_str(),
                  r.writing ? "  (writing)" : "", r.saved ? "  (saved)" : "");
    out << line;
  }
}

int list_command(const GlobalOptions& options, std::ostream& out, std::ostream& err) {
  Client client(client_options(options));
  if (const auto rc = connect(client, options, err)) return *rc;
  const auto list = list_recordings(client);
  if (!list) return refused(err, "blackbox list", list.error());
  print_recordings(*list, options, out);
  return kExitOk;
}

int save_command(const std::string& seconds_text, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err) {
  double seconds = 0;
  try {
    std::size_t used = 0;
    seconds = std::stod(seconds_text, &used);
    if (used != seconds_text.size()) throw std::invalid_argument(seconds_text);
  } catch (const std::exception&) {
    return usage(err, "save wants SECONDS, got '" + seconds_text + "'");
  }
  Client client(client_options(options));
  if (const auto rc = connect(client, options, err)) return *rc;
  const auto saved = save_recording(client, seconds);
  if (!saved) return refused(err, "blackbox save", saved.error());
  print_recordings(*saved, options, out);
  return kExitOk;
}

int fetch_command(const std::string& name, std::string path, const GlobalOptions& options,
                  std::ostream& out, std::ostream& err) {
  if (path.empty()) path = name.substr(name.rfind('/') + 1);
  Client client(client_options(options));
  if (const auto rc = connect(client, options, err)) return *rc;
  FetchOptions fetch;
  std::uint64_t last_report = 0;
  bool first = true;
  fetch.progress = [&](const FetchProgress& p) {
    if (first && p.resumed) err << "resuming " << path << " at " << p.offset << " bytes\n";
    // A line at the start, one per MiB, and one at the end.
    if (!first && p.offset < p.size_bytes && p.offset - last_report < (1U << 20)) return;
    first = false;
    last_report = p.offset;
    const double percent = p.size_bytes == 0 ? 100.0
                                             : 100.0 * static_cast<double>(p.offset) /
                                                   static_cast<double>(p.size_bytes);
    char line[160];
    std::snprintf(line, sizeof line, "fetch %s: %llu / %llu bytes (%.0f%%)\n", name.c_str(),
                  static_cast<unsigned long long>(p.offset),
                  static_cast<unsigned long long>(p.size_bytes), std::min(percent, 100.0));
    err << line;
  };
  if (const char* stop = std::getenv("AJARCTL_FETCH_STOP_AFTER_BYTES")) {  // tests: interrupt
    fetch.stop_after_bytes = std::strtoull(stop, nullptr, 10);
  }
  const auto size = fetch_recording(client, name, path, fetch);
  if (!size) return refused(err, "blackbox fetch", size.error());
  if (options.json) {
    out << ordered_json{{"type", "fetched"}, {"name", name}, {"file", path}, {"size_bytes", *size}}
               .dump()
        << "\n";
  } else {
    out << "fetched " << name << " -> " << path << " (" << *size << " bytes)\n";
  }
  return kExitOk;
}

// ---- show and export: a local file -----------------------------------------------------------

std::optional<recorder::McapFile> open_recording(const std::string& path, std::ostream& err) {
  std::string error;
  recorder::McapFile file = recorder::read_mcap(path, &error);
  if (!file.is_mcap) {
    err << "ajarctl: " << (error.empty() ? path + ": " + file.problem : error) << "\n";
    return std::nullopt;
  }
  if (!file.complete)
    err << "note: " << path << ": " << file.problem << "; read up to byte " << file.read_up_to
        << " of " << file.bytes.size() << "\n";
  return file;
}

std::string_view topic(recorder::McapFile const& file, std::uint16_t channel_id) {
  const auto it = file.channels.find(channel_id);
  return it == file.channels.end() ? std::string_view{} : std::string_view(it->second.topic);
}
std::string_view topic_of(std::uint16_t id) {
  const auto* c = recorder::channel_by_id(id);
  return c == nullptr ? std::string_view{} : c->topic;
}

bool noisy(protocol::MessageType t) {
  using protocol::MessageType;
  return t == MessageType::kPing || t == MessageType::kPong || t == MessageType::kTelemetry ||
         t == MessageType::kGetStatus || t == MessageType::kStatus ||
         t == MessageType::kSubscribe || t == MessageType::kFetchRecording ||
         t == MessageType::kRecordingChunk;
}

std::string time_text(std::uint64_t t_ns, std::uint64_t t0_ns) {
  char text[32];
  std::snprintf(text, sizeof text, "%+11.3f s",
                (static_cast<double>(t_ns) - static_cast<double>(t0_ns)) * 1e-9);
  return text;
}

std::string wire_text(const WireRecord& w) {
  if (!w.envelope) {
    return std::string(w.in ? "-> " : "<- ") + "undecodable frame: " + protocol::describe(w.error);
  }
  const protocol::Message& m = w.envelope->message;
  const auto type = protocol::type_of(m);
  std::string text = std::string(w.in ? "-> " : "<- ");
  if (w.in) {
    text += std::string(protocol::to_string(type)) + " (request " +
            std::to_string(w.envelope->request_id) + ")";
    if (const auto* hello = std::get_if<protocol::Hello>(&m)) {
      text += ": " + std::string(protocol::to_string(hello->requested_role)) +
              (hello->take_over ? " take_over" : "") + " \"" +
              std::string(hello->client_name.view()) + "\"";
    }
    return text;
  }
  Response r;
  r.reply = m;
  r.request_id = w.envelope->request_id;
  if (const auto* e = std::get_if<protocol::ErrorReply>(&m)) {
    r.outcome = CallOutcome::kRefused;
    r.error = *e;
  } else {
    r.outcome = CallOutcome::kReply;
  }
  std::string body = response_text(protocol::to_string(type), r);
  while (!body.empty() && body.back() == '\n')
    body.pop_back();
  std::replace(body.begin(), body.end(), '\n', ' ');
  return text + body + " (request " + std::to_string(w.envelope->request_id) + ")";
}

// show's lines: the time since the first line, who and what (with --json: the record's JSON with
// its daemon_time_ns, one object a line).
class ShowLines {
 public:
  ShowLines(bool json, std::ostream& out) : json_(json), out_(out) {}
  void line(std::uint64_t t, const std::string& who, const std::string& what,
            const ordered_json& json) {
    if (!have_t0_) {
      t0_ = t;
      have_t0_ = true;
    }
    ++lines_;
    if (json_) {
      ordered_json j = json;
      j["daemon_time_ns"] = t;
      out_ << j.dump() << "\n";
    } else {
      char who_text[24];
      std::snprintf(who_text, sizeof who_text, "%-11s", who.c_str());
      out_ << time_text(t, t0_) << "  " << who_text << " " << what << "\n";
    }
  }
  std::size_t count() const { return lines_; }

 private:
  bool json_;
  std::ostream& out_;
  std::uint64_t t0_ = 0;
  bool have_t0_ = false;
  std::size_t lines_ = 0;
};

// A record `j` of the events, faults, sessions or config channel (`t`), or with `all` of the
// recorder's own, as a line; records of other channels are not shown.
void show_channel_record(ShowLines& show, std::string_view t, const ordered_json& j, bool all) {
  const std::uint64_t time = j.value("daemon_time_ns", std::uint64_t{0});
  const auto s = [&j](const char* key) { return j.value(key, std::string()); };
  if (t == topic_of(recorder::kEventsChannel)) {
    std::string what = s("kind") + " -> " + s("state");
    if (s("fault") != "OK" && !s("fault").empty()) what += " " + s("fault");
    if (!s("detail").empty()) what += ": " + s("detail");
    show.line(time, "event", what, {{"type", "event"}, {"event", j}});
  } else if (t == topic_of(recorder::kFaultsChannel)) {
    show.line(time, "FAULT", s("change") + " " + s("code") + ": " + s("detail"),
              {{"type", "fault"}, {"fault", j}});
  } else if (t == topic_of(recorder::kSessionsChannel)) {
    std::string what = s("change");
    if (s("change") == "open") what += " from " + s("peer") + " as " + s("identity");
    if (s("change") == "role") what += " " + s("role");
    if (!s("detail").empty()) what += ": " + s("detail");
    show.line(time, "session " + std::to_string(j.value("session_id", std::uint64_t{0})), what,
              {{"type", "session"}, {"session", j}});
  } else if (t == topic_of(recorder::kConfigChannel)) {
    std::string what = s("reason") + " " + s("file");
    if (j.contains("changed_keys") && j["changed_keys"].is_array() && !j["changed_keys"].empty()) {
      what += " (changed:";
      for (const auto& k : j["changed_keys"])
        what += " " + k.get<std::string>();
      what += ")";
    }
    show.line(time, "config", what, {{"type", "config"}, {"reason", s("reason")}});
  } else if (t == topic_of(recorder::kRecorderChannel) && all) {
    show.line(time, "recorder", j.dump(), {{"type", "recorder"}, {"recorder", j}});
  }
}

int show_command(const std::string& path, bool all, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err) {
  const auto file = open_recording(path, err);
  if (!file) return kExitRefused;
  std::string problem;
  const auto wires = wire_records(*file, &problem);
  std::size_t wire_index = 0;
  ShowLines show(options.json, out);
  out << (options.json ? ""
                       : "recording " + path + ": " + std::to_string(file->messages.size()) +
                             " messages" + (file->complete ? "" : " (cut short)") + "\n");
  for (const auto& m : file->messages) {
    const std::string_view t = topic(*file, m.channel_id);
    if (t == topic_of(recorder::kWireChannel)) {
      if (wire_index >= wires.size()) continue;
      const WireRecord& w = wires[wire_index++];
      if (w.envelope) {
        const auto type = protocol::type_of(w.envelope->message);
        // Events are shown once, from their own channel; the rest of the noise with --all.
        if (type == protocol::MessageType::kEvent || (!all && noisy(type))) continue;
      }
      show.line(w.daemon_time_ns, "session " + std::to_string(w.session_id), wire_text(w),
                {{"type", "wire"},
                 {"session_id", w.session_id},
                 {"direction", w.in ? "in" : "out"},
                 {"text", wire_text(w)}});
      continue;
    }
    const auto data = file->data(m);
    const ordered_json j =
        ordered_json::parse(data.begin(), data.end(), nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) continue;
    show_channel_record(show, t, j, all);
  }
  if (!problem.empty()) err << "note: " << problem << "\n";
  if (!options.json) out << show.count() << " lines\n";
  return kExitOk;
}

// The loop trace as CSV: one row per /ajar/loop message, the columns its JSON's leaves (nested
// objects joined with '.'), in the order the recorder writes them.
void flatten(const ordered_json& j, const std::string& prefix,
             std::vector<std::pair<std::string, std::string>>& out) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it->is_object()) {
      flatten(*it, key, out);
    } else if (it->is_string()) {
      out.emplace_back(key, it->get<std::string>());
    } else {
      out.emplace_back(key, it->dump());
    }
  }
}

int export_command(const std::string& path, const std::string& output, std::ostream& out,
                   std::ostream& err) {
  const auto file = open_recording(path, err);
  if (!file) return kExitRefused;
  std::ofstream file_out;
  if (!output.empty()) {
    file_out.open(output);
    if (!file_out) {
      err << "ajarctl: cannot write " << output << "\n";
      return kExitRefused;
    }
  }
  std::ostream& csv = output.empty() ? out : file_out;
  std::vector<std::string> columns;
  std::size_t rows = 0;
  for (const auto& m : file->messages) {
    if (topic(*file, m.channel_id) != topic_of(recorder::kLoopChannel)) continue;
    const auto data = file->data(m);
    const ordered_json j = ordered_json::parse(data.begin(), data.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) continue;
    std::vector<std::pair<std::string, std::string>> cells;
    flatten(j, "", cells);
    if (columns.empty()) {
      for (const auto& [k, v] : cells)
        columns.push_back(k);
      for (std::size_t i = 0; i < columns.size(); ++i)
        csv << (i ? "," : "") << columns[i];
      csv << "\n";
    }
    std::map<std::string, std::string> by_key(cells.begin(), cells.end());
    for (std::size_t i = 0; i < columns.size(); ++i)
      csv << (i ? "," : "") << by_key[columns[i]];
    csv << "\n";
    ++rows;
  }
  err << rows << " loop samples" << (output.empty() ? "" : " written to " + output) << "\n";
  return kExitOk;
}

}  // namespace

std::vector<WireRecord> wire_records(const recorder::McapFile& file, std::string* problem) {
  std::vector<WireRecord> out;
  const recorder::McapChannel* wire = file.channel(topic_of(recorder::kWireChannel));
  if (wire == nullptr) {
    if (problem != nullptr)
      *problem =
          "the recording has no " + std::string(topic_of(recorder::kWireChannel)) + " channel";
    return out;
  }
  std::size_t bad = 0;
  for (const auto& m : file.messages) {
    if (m.channel_id != wire->id) continue;
    const auto d = file.data(m);
    if (d.size() < recorder::kWireHeaderBytes || d[0] != recorder::kWireLayoutVersion) {
      ++bad;
      continue;
    }
    WireRecord w;
    w.in = d[1] == recorder::kWireIn;
    for (int i = 7; i >= 0; --i) {
      w.session_id = (w.session_id << 8) | d[2 + static_cast<std::size_t>(i)];
      w.daemon_time_ns = (w.daemon_time_ns << 8) | d[10 + static_cast<std::size_t>(i)];
    }
    w.frame.assign(d.begin() + recorder::kWireHeaderBytes, d.end());
    const auto decoded = protocol::decode_frame(w.frame);
    if (decoded.kind == protocol::StreamDecoder::Kind::kMessage) {
      w.envelope = decoded.envelope;
    } else {
      w.error = decoded.error;
    }
    out.push_back(std::move(w));
  }
  if (bad > 0 && problem != nullptr) {
    *problem = std::to_string(bad) + " wire messages of an unknown layout were skipped";
  }
  return out;
}

int run_blackbox(const Command& command, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err) {
  const auto& a = command.args;
  if (a.empty()) return usage(err, "no subcommand");
  const std::string& sub = a[0];
  if (sub == "list") {
    if (a.size() != 1) return usage(err, "list takes no arguments");
    return list_command(options, out, err);
  }
  if (sub == "save") {
    if (a.size() != 2) return usage(err, "save wants SECONDS");
    return save_command(a[1], options, out, err);
  }
  std::string file, output;
  bool csv = false, all = false;
  for (std::size_t i = 1; i < a.size(); ++i) {
    if ((a[i] == "-o" || a[i] == "--output") && i + 1 < a.size()) {
      output = a[++i];
    } else if (a[i] == "--csv") {
      csv = true;
    } else if (a[i] == "--all") {
      all = true;
    } else if (a[i].starts_with("-")) {
      return usage(err, "unknown option '" + a[i] + "'");
    } else if (file.empty()) {
      file = a[i];
    } else {
      return usage(err, "unexpected '" + a[i] + "'");
    }
  }
  if (file.empty()) return usage(err, sub + " wants a " + (sub == "fetch" ? "NAME" : "FILE"));
  if (sub == "fetch" && !csv && !all) return fetch_command(file, output, options, out, err);
  if (sub == "show" && !csv && output.empty()) return show_command(file, all, options, out, err);
  if (sub == "export") {
    if (!csv) return usage(err, "export wants --csv (the loop trace)");
    return export_command(file, output, out, err);
  }
  return usage(err, "unknown subcommand or options for '" + sub + "'");
}

}  // namespace ajar::client
