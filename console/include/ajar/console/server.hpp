// ajar-console's server: the bridge between one ajard (through ajar_client) and the operator's
// browser (HTTP for the page's files, one WebSocket per open page). See docs/console.md.
//
// Threads: one Asio thread owns the listening socket, every page's WebSocket and all console state
// (picks, results, the latest frames, the daemon's status); a frame thread paces the frame source
// and encodes PNGs; a daemon worker makes the blocking ajar_client calls (connect, Hello,
// measurements, commands) and a second one only Stop and EmergencyStop, so a stop never waits
// behind another request. Results are posted back to the Asio thread.
//
// Safety: the console feeds the daemon's deadman (Client heartbeat) only while at least one page is
// connected over its WebSocket and has said "alive" within kPageAliveTimeout; closing the tab or
// losing the WebSocket stops the heartbeat, and the daemon's deadman stops any motion.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "ajar/client/client.hpp"
#include "ajar/console/frame.hpp"

namespace ajar::console {

class SimulatedSource;

inline constexpr std::chrono::milliseconds kPageAliveTimeout{1500};
// The watchdog (issue 23): a camera frame or a telemetry sample older than this is FROZEN. The page
// greys the image and refuses picks; the console refuses a pick on a frame when the camera has
// sent nothing newer for this long, or when the base's pose at that frame is older than this (no
// telemetry: where the base was is unknown), and refuses to send picks without a fresh pose.
inline constexpr std::chrono::milliseconds kFrozenAfter{600};

struct ConsoleOptions {
  client::Endpoint daemon;                // ajard to connect to
  std::string listen_host = "127.0.0.1";  // the page's address; loopback by default
  std::uint16_t listen_port = 8080;       // 0: any free port
  std::string web_dir;                    // index.html, console.js, console.css
  protocol::Role role = protocol::Role::kController;
  bool take_over = false;
  float telemetry_rate_hz = 20;
  // Mutual TLS to ajard (docs/security.md), on when tls.ca is set: --ca, --cert, --key. The files
  // are checked by listen() with ajarctl's rule (a private key readable by group or others is
  // refused). The page itself is plain HTTP: keep listen_host on loopback (docs/console.md).
  client::TlsOptions tls;
  // Foxglove live (docs/console.md): the Foxglove WebSocket protocol on a second port, loopback
  // only (listen() refuses another address). Off unless foxglove is set (--foxglove HOST:PORT).
  bool foxglove = false;
  std::string foxglove_host = "127.0.0.1";
  std::uint16_t foxglove_port = 8765;  // 0: any free port
};

class ConsoleServer {
 public:
  // `sim` (may be null) is the same object as `source` when the source is the simulated camera: it
  // receives the daemon's camera calibration and serves /api/sim/landmarks.
  ConsoleServer(ConsoleOptions options, std::unique_ptr<FrameSource> source, SimulatedSource* sim);
  ~ConsoleServer();
  ConsoleServer(const ConsoleServer&) = delete;
  ConsoleServer& operator=(const ConsoleServer&) = delete;

  // Checks the TLS files (throws std::runtime_error naming the option: --ca, --cert, --key), binds
  // the listening socket (throws std::runtime_error naming the address on failure) and returns the
  // bound port.
  std::uint16_t listen();
  // The Foxglove port listen() bound (0 when Foxglove live is off). listen() throws naming
  // --foxglove when its address is not loopback or cannot be bound.
  std::uint16_t foxglove_port() const;
  // Runs until stop() or SIGINT/SIGTERM; then closes the pages, stops the heartbeat and
  // disconnects from ajard.
  void run();
  void stop();  // thread-safe

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ajar::console
