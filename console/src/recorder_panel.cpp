// The page's black-box panel (docs/console.md, "The black box"): the recorder's state as ajard
// reports it (protocol 1.2: Status.recorder — mode, file, bytes, records written, dropped, lost)
// and "save the last 5 minutes" (SaveRecording through ajar_client's black-box API). Worker
// thread: refresh_recorder (a GetStatus every 2 s), status_received and the save's request; the
// state the page draws: the Asio thread. What ajard has not said is "unknown" with the reason (an
// older daemon, no link, a console without the 1.2 client).
#include "server_impl.hpp"

#include "ajar/client/output.hpp"

#if __has_include("ajar/client/blackbox.hpp")
#include "ajar/client/blackbox.hpp"
#define AJAR_CONSOLE_HAVE_BLACKBOX 1
#else
#define AJAR_CONSOLE_HAVE_BLACKBOX 0
#endif

namespace ajar::console {

namespace {

// ajard's refusal as the page reads a reply (daemon_json.cpp's response_json shape).
client::JsonObject refusal(std::string_view code, std::string_view field,
                           std::string_view message) {
  return client::JsonObject()
      .add("ok", false)
      .add("code", code)
      .add("field", field)
      .add("message", message);
}

// Why the recorder's state or a save cannot be had from this daemon now ("" when it can).
std::string unavailable(client::Client& c) {
  const auto w = c.welcome();
  if (!c.connected() || !w) return "no link to ajard";
  if (w->version_minor < 2) {
    return "ajard speaks protocol " + std::to_string(w->version_major) + "." +
           std::to_string(w->version_minor) + "; the black box needs 1.2";
  }
  if (!AJAR_CONSOLE_HAVE_BLACKBOX) return "this console has no black-box client (protocol 1.2)";
  return "";
}

// Why a recorder that is not recording is not, in the operator's words.
std::string_view not_recording(const protocol::RecorderState& r) {
  switch (r.mode) {
    case protocol::RecorderMode::kRecording:
      return "";
    case protocol::RecorderMode::kDiskFull:
      return "the disk is full: recording paused, retried every 5 s";
    case protocol::RecorderMode::kDiskError:
      return "the disk refused a write: recording paused, retried every 5 s";
    case protocol::RecorderMode::kNoDirectory:
      return "its directory cannot be written: off until ajard restarts";
    case protocol::RecorderMode::kOff:
      break;
  }
  return r.enabled ? "not started" : "the recorder is off on this daemon (recorder.enabled: false)";
}

// The page's recorder object from Status.recorder: every number as ajard sent it.
client::JsonObject panel_state(const protocol::RecorderState& r) {
  client::JsonObject o;
  o.add("known", true)
      .add("on", r.mode == protocol::RecorderMode::kRecording)
      .add("mode", protocol::to_string(r.mode));
  if (const auto why = not_recording(r); !why.empty()) o.add("why", why);
  if (r.file.length > 0) o.add("file", r.file.view()).add("size_bytes", r.file_bytes);
  o.add("drops", r.loop_dropped + r.io_dropped)
      .add("recorder", client::recorder_object(r));  // the whole block, wire names
  return o;
}

}  // namespace

// Asks for a Status (status_received below makes the panel's state of its recorder block).
void ConsoleServer::Impl::refresh_recorder() {
  next_recorder_poll = Clock::now() + std::chrono::seconds(2);
  if (const auto why = unavailable(link.client()); !why.empty()) {
    set_recorder_state(client::JsonObject().add("known", false).add("why", why));
    return;
  }
  link.refresh_status();
}

// Worker thread, with the Status ajard sent on this link.
void ConsoleServer::Impl::recorder_status(const protocol::Status& s) {
  if (!unavailable(link.client()).empty()) return;  // refresh_recorder says why
  set_recorder_state(panel_state(s.recorder));
}

void ConsoleServer::Impl::set_recorder_state(client::JsonObject o) {
  on_io([this, o = std::move(o)] {
    if (o.str() == recorder_state.str()) return;
    recorder_state = o;
    mark_dirty();
  });
}

// The daemon checks `last_s` (REQUEST_OUT_OF_RANGE on last_s): the page's button asks for 300 s.
void ConsoleServer::Impl::save_recording(double last_s) {
  recorder_save = client::JsonObject().add("pending", true).add("at", now_hms());
  add_log("asking ajard to save the last " + std::to_string(static_cast<long>(last_s)) +
          " s of its black box");
  mark_dirty();
  link.post([this, last_s] {
    client::JsonObject reply;
    client::JsonArray saved;
    if (const auto why = unavailable(link.client()); !why.empty()) {
      reply = refusal(ajar::to_string(ErrorCode::kNotSupported), "", why);
    } else {
#if AJAR_CONSOLE_HAVE_BLACKBOX
      const auto r = client::save_recording(link.client(), last_s);
      if (r) {
        reply = client::JsonObject().add("ok", true);
        for (const auto& info : *r)
          saved.add(info.name.view());
      } else {
        reply = refusal(ajar::to_string(r.error().code), r.error().field, r.error().message);
      }
#endif
    }
    on_io([this, reply, saved] {
      recorder_save =
          client::JsonObject().add("at", now_hms()).add("reply", reply).add("saved", saved);
      add_log("black box: save: " + reply.str());
      mark_dirty();
    });
    refresh_recorder();
  });
}

}  // namespace ajar::console
