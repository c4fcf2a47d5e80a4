// ajar-console: the operator console (docs/console.md).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "ajar/client/cli.hpp"
#include "ajar/client/simulate.hpp"
#include "ajar/console/door_scene.hpp"
#include "ajar/console/openni_source.hpp"
#include "ajar/console/server.hpp"
#include "ajar/console/tum.hpp"
#include "ajar/core/geometry.hpp"
#include "ajar/protocol/endpoint.hpp"
#include "ajar/version.hpp"

namespace {

constexpr const char* kDescription =
    R"(Serves the operator console (the paper's point-at-the-RGBD-image GUI) to a browser and speaks
the Ajar protocol to ajard. Open the printed URL.)";

// CLI11's help in ajar-console's own layout (as before CLI11): the usage line, the description
// indented, then one option a line, NAME TYPE in a column of 24 and its help after it (a "\n" in
// the help continues under it); --help and --version last, on one line.
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_help(const CLI::App* app, std::string, CLI::AppFormatMode) const override {
    constexpr std::size_t kColumn = 24;
    std::string out = "usage: ajar-console [options]\n";
    out += indented("  ", app->get_description()) + "\n";
    for (const CLI::Option* o : app->get_options()) {
      const std::string& name = o->get_lnames().front();
      if (name == "help" || name == "version") continue;
      std::string left = "  --" + name;
      if (!o->get_type_name().empty()) left += " " + o->get_type_name();
      left.resize(std::max(kColumn, left.size() + 2), ' ');
      out += left + indented(std::string(kColumn, ' '), o->get_description()).substr(kColumn);
    }
    return out + "  --help, --version\n";
  }

 private:
  // Each line of `text` after `indent`, each ended by a newline.
  static std::string indented(const std::string& indent, const std::string& text) {
    std::string out;
    std::size_t from = 0;
    for (std::size_t end; (end = text.find('\n', from)) != std::string::npos; from = end + 1)
      out += indent + text.substr(from, end - from) + "\n";
    return out + indent + text.substr(from) + "\n";
  }
};

struct Args {
  ajar::console::ConsoleOptions options;
  std::string source = "sim";
  std::string scenario;
  std::string recorded;
  std::string device;
  double fps = 15;
  std::string record;
  int frames = 3;
  int scale = 1;
};

std::string usage_text();

[[noreturn]] void usage_error(const std::string& what) {
  std::cerr << "ajar-console: " << what << "\n" << usage_text();
  std::exit(2);
}

std::string default_path(const char* relative) {
  // The source tree's (or the install prefix's) file, found relative to the executable's folder.
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  for (fs::path dir = exe.parent_path(); !dir.empty() && dir != dir.root_path();
       dir = dir.parent_path()) {
    if (fs::exists(dir / relative)) return (dir / relative).string();
    if (fs::exists(dir / "share/ajar" / relative)) return (dir / "share/ajar" / relative).string();
  }
  return relative;
}

// An option NAME TYPE whose value `apply` takes as it is read (trigger_on_parse).
void add_text(CLI::App& app, const char* name, const char* type, const char* help,
              std::function<void(const std::string&)> apply) {
  app.add_option_function<std::string>(name, std::move(apply), help)
      ->type_name(type)
      ->trigger_on_parse();
}

// Where ajard is and where the page is served.
void add_addresses(CLI::App& app, Args& a) {
  add_text(app, "--connect", "HOST:PORT", "ajard to connect to (default 127.0.0.1:7450)",
           [&a](const std::string& v) {
             const auto e = ajar::client::parse_endpoint(v);
             if (!e) usage_error("--connect: expected HOST:PORT");
             a.options.daemon = *e;
           });
  add_text(app, "--listen", "HOST:PORT",
           "address of the page (default 127.0.0.1:8080; port 0 = any free port)",
           [&a](const std::string& v) {
             auto e = ajar::protocol::parse_host_port(v, ajar::protocol::PortZero::kAllowed);
             if (!e)
               usage_error("--listen: expected HOST:PORT (port 0..65535; IPv6 as [::1]:8080)");
             a.options.listen_host = std::move(e->host);
             a.options.listen_port = e->port;
           });
}

// The camera: simulated, recorded or live, and what each takes.
void add_camera(CLI::App& app, Args& a) {
  add_text(app, "--source", "KIND", "camera: sim (default), recorded, live (OpenNI2)",
           [&a](const std::string& v) {
             if (v != "sim" && v != "recorded" && v != "live") {
               usage_error("--source: sim, recorded or live");
             }
             a.source = v;
           });
  add_text(app, "--scenario", "FILE",
           "sim: the door scene (default config/scenarios/console-door.yaml)",
           [&a](const std::string& v) { a.scenario = v; });
  add_text(app, "--recorded", "DIR", "recorded: a folder in the TUM RGB-D layout (docs/console.md)",
           [&a](const std::string& v) {
             a.recorded = v;
             a.source = "recorded";
           });
  add_text(app, "--device", "URI", "live: the OpenNI2 device URI (default: the first sensor)",
           [&a](const std::string& v) { a.device = v; });
  add_text(app, "--fps", "HZ", "sim: frame rate (default 15)", [&a](const std::string& v) {
    a.fps = std::atof(v.c_str());
    if (!(a.fps >= 0.5 && a.fps <= 60)) usage_error("--fps: 0.5..60");
  });
}

// What the console serves besides the page's address: Foxglove live and the page's files.
void add_served(CLI::App& app, Args& a) {
  add_text(app, "--foxglove", "HOST:PORT",
           "also serve Foxglove live (foxglove.websocket.v1) on this loopback\n"
           "address, e.g. 127.0.0.1:8765 (port 0 = any free port; default off)",
           [&a](const std::string& v) {
             auto e = ajar::protocol::parse_host_port(v, ajar::protocol::PortZero::kAllowed);
             if (!e) usage_error("--foxglove: expected HOST:PORT (e.g. 127.0.0.1:8765)");
             a.options.foxglove = true;
             a.options.foxglove_host = std::move(e->host);
             a.options.foxglove_port = e->port;
           });
  add_text(app, "--web", "DIR", "the page's files (default: the installed/source web folder)",
           [&a](const std::string& v) { a.options.web_dir = v; });
}

// Mutual TLS to ajard, given here or by ajarctl's client config file.
void add_tls(CLI::App& app, Args& a) {
  add_text(app, "--ca", "FILE", "mutual TLS to ajard: the CA that signed ajard's certificate (PEM)",
           [&a](const std::string& v) { a.options.tls.ca = v; });
  add_text(app, "--cert", "FILE",
           "with --ca: this console's certificate (PEM), made by scripts/make-certs",
           [&a](const std::string& v) { a.options.tls.certificate = v; });
  add_text(app, "--key", "FILE",
           "with --ca: its private key (mode 0600: refused when group/world readable)",
           [&a](const std::string& v) { a.options.tls.private_key = v; });
  add_text(app, "--server-name", "NAME",
           "with --ca: the name in ajard's certificate (default: the --connect host)",
           [&a](const std::string& v) { a.options.tls.server_name = v; });
  add_text(app, "--client-config", "FILE",
           "connect and tls from ajarctl's client config file (docs/ajarctl.md);\n"
           "options after it override it",
           [&a](const std::string& v) {
             // ajarctl's loader: one file format for every host-side program.
             const std::vector<std::string> words{"--client-config", v};
             const auto parsed = ajar::client::parse_global_options(words);
             if (!parsed.error.empty()) usage_error(parsed.error);
             a.options.daemon = parsed.options.endpoint;
             a.options.tls = parsed.options.tls;
           });
}

// The role the console asks ajard for.
void add_role(CLI::App& app, Args& a) {
  app.add_flag_callback(
         "--observer", [&a] { a.options.role = ajar::protocol::Role::kObserver; },
         "connect as an observer (default: controller)")
      ->trigger_on_parse();
  app.add_flag_callback(
         "--take-over", [&a] { a.options.take_over = true; },
         "take control from the current controller")
      ->trigger_on_parse();
}

// Writing the simulated camera's frames to disk instead of serving.
void add_record(CLI::App& app, Args& a) {
  add_text(app, "--record", "DIR",
           "sim: write --frames rendered frames in the TUM layout to DIR and exit",
           [&a](const std::string& v) { a.record = v; });
  add_text(app, "--frames", "N", "with --record (default 3)", [&a](const std::string& v) {
    a.frames = std::atoi(v.c_str());
    if (a.frames < 1 || a.frames > 1000) usage_error("--frames: 1..1000");
  });
  add_text(app, "--scale", "S", "with --record: image size divided by S (default 1)",
           [&a](const std::string& v) {
             a.scale = std::atoi(v.c_str());
             if (a.scale < 1 || a.scale > 16) usage_error("--scale: 1..16");
           });
}

// The one description of ajar-console's options: parse() parses with it, --help prints it. Every
// option acts when it is read (trigger_on_parse), in the order of the command line: options after
// --client-config override it. The help lists them in the order they are added here.
std::unique_ptr<CLI::App> make_parser(Args& a, bool& version) {
  auto app = std::make_unique<CLI::App>(kDescription, "ajar-console");
  app->formatter(std::make_shared<HelpFormatter>());
  app->set_help_flag("-h,--help", "print this help and exit");
  add_addresses(*app, a);
  add_camera(*app, a);
  add_served(*app, a);
  add_tls(*app, a);
  add_role(*app, a);
  add_record(*app, a);
  app->add_flag("--version", version, "print the version and exit");
  return app;
}

std::string usage_text() {
  Args ignored;
  bool version = false;
  return make_parser(ignored, version)->help();
}

Args parse(int argc, char** argv) {
  Args a;
  a.options.web_dir = AJAR_CONSOLE_DEFAULT_WEB_DIR;
  bool version = false;
  const auto app = make_parser(a, version);
  try {
    app->parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app->help();
    std::exit(0);
  } catch (const CLI::ParseError& e) {
    usage_error(e.what());
  }
  if (version) {
    std::cout << "ajar-console " << ajar::kVersion << "\n";
    std::exit(0);
  }
  if (a.scenario.empty()) {
    a.scenario = default_path("config/scenarios/console-door.yaml");
    if (!std::filesystem::exists(a.scenario)) {
      a.scenario = default_path("examples/scenarios/console-door.yaml");  // installed
    }
  }
  if (!std::filesystem::exists(std::filesystem::path(a.options.web_dir) / "index.html")) {
    a.options.web_dir = default_path("console/web");
  }
  return a;
}

int record(const Args& a, const ajar::client::Scenario& scenario) {
  ajar::console::SensorModel sensor;
  sensor.depth_noise_at_1m_m = scenario.depth_noise_at_1m_m;
  auto& k = sensor.intrinsics;
  k.fx_px /= a.scale;
  k.fy_px /= a.scale;
  k.width_px /= a.scale;
  k.height_px /= a.scale;
  k.cx_px = (k.width_px - 1) / 2.0;
  k.cy_px = (k.height_px - 1) / 2.0;
  ajar::console::DoorScene scene(scenario, sensor);
  Eigen::Isometry3d t;
  t.matrix() = ajar::core::paper_camera_to_base_m();
  const ajar::console::TumCamera camera{k, 5000.0, 10.0};
  for (int i = 0; i < a.frames; ++i) {
    ajar::console::Frame f;
    // Turn the base a little between frames, as an operator driving would.
    scene.render({0, 0, 0.02 * i}, t, static_cast<std::uint64_t>(i + 1), true, f);
    f.timestamp_s = 1.0 + 0.1 * i;
    std::string error;
    if (!ajar::console::write_tum_frame(a.record, f, camera, error)) {
      std::cerr << "ajar-console: " << error << "\n";
      return 1;
    }
  }
  std::cout << "ajar-console: wrote " << a.frames << " frames to " << a.record << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  try {
    std::unique_ptr<ajar::console::FrameSource> source;
    ajar::console::SimulatedSource* sim = nullptr;
    if (a.source == "sim" || !a.record.empty()) {
      const auto scenario = ajar::client::load_scenario(a.scenario);
      if (!a.record.empty()) return record(a, scenario);
      ajar::console::SensorModel sensor;
      sensor.depth_noise_at_1m_m = scenario.depth_noise_at_1m_m;
      // Until the daemon's RobotModel arrives the simulated camera sits where the paper's eq. 2
      // puts it; the console replaces it with the daemon's calibration when it has it.
      auto s = std::make_unique<ajar::console::SimulatedSource>(
          a.scenario, scenario, sensor, a.fps, ajar::core::paper_camera_to_base_m());
      sim = s.get();
      source = std::move(s);
    } else if (a.source == "recorded") {
      if (a.recorded.empty()) usage_error("--source recorded needs --recorded DIR");
      ajar::console::TumSequence seq;
      std::string error;
      if (!ajar::console::load_tum_sequence(a.recorded, seq, error)) {
        std::cerr << "ajar-console: " << error << "\n";
        return 2;
      }
      source = std::make_unique<ajar::console::RecordedSource>(std::move(seq));
    } else {
      std::string error;
      source = ajar::console::make_live_source(a.device, error);
      if (!source) {
        std::cerr << "ajar-console: " << error << "\n";
        return 2;
      }
    }
    const auto& lh = a.options.listen_host;
    if (lh.rfind("127.", 0) != 0 && lh != "::1") {
      std::cerr << "ajar-console: warning: listening on " << lh
                << " exposes the robot's controls without authentication to that network; "
                   "prefer 127.0.0.1 and an SSH tunnel (docs/console.md)\n";
    }
    ajar::console::ConsoleServer server(a.options, std::move(source), sim);
    const auto port = server.listen();
    std::string host = a.options.listen_host;
    if (host.find(':') != std::string::npos) host = "[" + host + "]";
    std::printf("ajar-console: open http://%s:%u/ in a browser (ajard at %s:%u, %s)\n",
                host.c_str(), static_cast<unsigned>(port), a.options.daemon.host.c_str(),
                static_cast<unsigned>(a.options.daemon.port),
                a.options.tls.enabled() ? "mutual TLS" : "plaintext");
    if (server.foxglove_port() != 0) {
      std::string fhost = a.options.foxglove_host;
      if (fhost.find(':') != std::string::npos) fhost = "[" + fhost + "]";
      std::printf("ajar-console: Foxglove live at ws://%s:%u/ (foxglove.websocket.v1)\n",
                  fhost.c_str(), static_cast<unsigned>(server.foxglove_port()));
    }
    std::fflush(stdout);
    server.run();
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "ajar-console: " << e.what() << "\n";
    return 2;
  }
}
