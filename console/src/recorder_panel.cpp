// The page's black-box panel (docs/console.md, "The black box"): the recorder's state as ajard
// reports it (protocol 1.2: the recording being written, from ListRecordings) and "save the last 5
// minutes" (SaveRecording through ajar_client's black-box API). Worker thread: refresh_recorder
// and the save's request; the state the page draws: the Asio thread. What ajard has not said is
// "unknown" with the reason (an older daemon, no link, a console without the 1.2 client).
#include "server_impl.hpp"

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

}  // namespace

void ConsoleServer::Impl::refresh_recorder() {
  next_recorder_poll = Clock::now() + std::chrono::seconds(2);
  client::JsonObject o;
  if (const auto why = unavailable(link.client()); !why.empty()) {
    o.add("known", false).add("why", why);
  } else {
#if AJAR_CONSOLE_HAVE_BLACKBOX
    const auto list = client::list_recordings(link.client());
    if (!list && list.error().code == ErrorCode::kNotSupported) {
      o.add("known", true).add("on", false).add("why", list.error().message);
    } else if (!list) {
      o.add("known", false).add("why", "ListRecordings: " + list.error().message);
    } else {
      const protocol::RecordingInfo* writing = nullptr;
      for (const auto& r : *list) {
        if (r.writing && writing == nullptr) writing = &r;
      }
      o.add("known", true).add("on", writing != nullptr).add("recordings", list->size());
      if (writing != nullptr) {
        o.add("file", writing->name.view()).add("size_bytes", writing->size_bytes);
      } else {
        o.add("why", "no recording is being written");
      }
      // Dropped records come with the recorder's counters in Status; until then: unknown.
      o.add_null("drops");
    }
#endif
  }
  on_io([this, o] {
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
