// ajar-console: the operator console (docs/console.md).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

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

constexpr const char* kUsage = R"(usage: ajar-console [options]
  Serves the operator console (the paper's point-at-the-RGBD-image GUI) to a browser and speaks
  the Ajar protocol to ajard. Open the printed URL.

  --connect HOST:PORT   ajard to connect to (default 127.0.0.1:7450)
  --listen HOST:PORT    address of the page (default 127.0.0.1:8080; port 0 = any free port)
  --source KIND         camera: sim (default), recorded, live (OpenNI2)
  --scenario FILE       sim: the door scene (default config/scenarios/console-door.yaml)
  --recorded DIR        recorded: a folder in the TUM RGB-D layout (docs/console.md)
  --device URI          live: the OpenNI2 device URI (default: the first sensor)
  --fps HZ              sim: frame rate (default 15)
  --foxglove HOST:PORT  also serve Foxglove live (foxglove.websocket.v1) on this loopback
                        address, e.g. 127.0.0.1:8765 (port 0 = any free port; default off)
  --web DIR             the page's files (default: the installed/source web folder)
  --ca FILE             mutual TLS to ajard: the CA that signed ajard's certificate (PEM)
  --cert FILE           with --ca: this console's certificate (PEM), made by scripts/make-certs
  --key FILE            with --ca: its private key (mode 0600: refused when group/world readable)
  --server-name NAME    with --ca: the name in ajard's certificate (default: the --connect host)
  --client-config FILE  connect and tls from ajarctl's client config file (docs/ajarctl.md);
                        options after it override it
  --observer            connect as an observer (default: controller)
  --take-over           take control from the current controller
  --record DIR          sim: write --frames rendered frames in the TUM layout to DIR and exit
  --frames N            with --record (default 3)
  --scale S             with --record: image size divided by S (default 1)
  --help, --version
)";

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

[[noreturn]] void usage_error(const std::string& what) {
  std::cerr << "ajar-console: " << what << "\n" << kUsage;
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

Args parse(int argc, char** argv) {
  Args a;
  a.options.web_dir = AJAR_CONSOLE_DEFAULT_WEB_DIR;
  std::vector<std::string> v(argv + 1, argv + argc);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string& o = v[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= v.size()) usage_error(o + " needs a value");
      return v[++i];
    };
    if (o == "--help" || o == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (o == "--version") {
      std::cout << "ajar-console " << ajar::kVersion << "\n";
      std::exit(0);
    } else if (o == "--connect") {
      const auto e = ajar::client::parse_endpoint(value());
      if (!e) usage_error("--connect: expected HOST:PORT");
      a.options.daemon = *e;
    } else if (o == "--listen") {
      auto e = ajar::protocol::parse_host_port(value(), ajar::protocol::PortZero::kAllowed);
      if (!e) usage_error("--listen: expected HOST:PORT (port 0..65535; IPv6 as [::1]:8080)");
      a.options.listen_host = std::move(e->host);
      a.options.listen_port = e->port;
    } else if (o == "--foxglove") {
      auto e = ajar::protocol::parse_host_port(value(), ajar::protocol::PortZero::kAllowed);
      if (!e) usage_error("--foxglove: expected HOST:PORT (e.g. 127.0.0.1:8765)");
      a.options.foxglove = true;
      a.options.foxglove_host = std::move(e->host);
      a.options.foxglove_port = e->port;
    } else if (o == "--source") {
      a.source = value();
      if (a.source != "sim" && a.source != "recorded" && a.source != "live") {
        usage_error("--source: sim, recorded or live");
      }
    } else if (o == "--scenario") {
      a.scenario = value();
    } else if (o == "--recorded") {
      a.recorded = value();
      a.source = "recorded";
    } else if (o == "--device") {
      a.device = value();
    } else if (o == "--fps") {
      a.fps = std::atof(value().c_str());
      if (!(a.fps >= 0.5 && a.fps <= 60)) usage_error("--fps: 0.5..60");
    } else if (o == "--web") {
      a.options.web_dir = value();
    } else if (o == "--ca") {
      a.options.tls.ca = value();
    } else if (o == "--cert") {
      a.options.tls.certificate = value();
    } else if (o == "--key") {
      a.options.tls.private_key = value();
    } else if (o == "--server-name") {
      a.options.tls.server_name = value();
    } else if (o == "--client-config") {
      // ajarctl's loader: one file format for every host-side program.
      const std::vector<std::string> words{o, value()};
      const auto parsed = ajar::client::parse_global_options(words);
      if (!parsed.error.empty()) usage_error(parsed.error);
      a.options.daemon = parsed.options.endpoint;
      a.options.tls = parsed.options.tls;
    } else if (o == "--observer") {
      a.options.role = ajar::protocol::Role::kObserver;
    } else if (o == "--take-over") {
      a.options.take_over = true;
    } else if (o == "--record") {
      a.record = value();
    } else if (o == "--frames") {
      a.frames = std::atoi(value().c_str());
      if (a.frames < 1 || a.frames > 1000) usage_error("--frames: 1..1000");
    } else if (o == "--scale") {
      a.scale = std::atoi(value().c_str());
      if (a.scale < 1 || a.scale > 16) usage_error("--scale: 1..16");
    } else {
      usage_error("unknown option " + o);
    }
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
