// Ajar live in Foxglove: the channels ajar-console serves on its Foxglove WebSocket port
// (foxglove::Server, ajar/console/foxglove_server.hpp) and the messages on them, built from what
// the console already receives from ajard (telemetry, events, Status, the RobotModel) and from its
// camera. docs/console.md, "Ajar live in Foxglove", lists the channels.
//
// Frames: `odom` (the odometry frame: the base frame when ajard started), `base_link` (the base
// frame of the paper, +x forward, +y left, +z up), `camera` (the RGBD camera's optical frame: +x
// right, +y down, +z forward, as core/camera.hpp deprojects). Times: the console's wall clock when
// the sample arrived (ns since the Unix epoch), the same as the messageData log time.
//
// Every method is cheap for its caller: it returns at once when nobody subscribes to the channel,
// and otherwise hands copies to the Foxglove server's thread, where the JSON is built.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ajar/console/foxglove_server.hpp"
#include "ajar/core/camera.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::console {

// The channel ids (also the order of the advertise message).
enum FoxgloveChannel : std::uint32_t {
  kFoxgloveTelemetry = 1,    // /ajar/telemetry        ajar.Telemetry (the recorder's rows,
  kFoxgloveEvents = 2,       // /ajar/events           ajar.Event      recorder/channels.hpp)
  kFoxgloveOdometry = 3,     // /tf                    foxglove.FrameTransform odom -> base_link
  kFoxgloveCameraMount = 4,  // /tf_static             foxglove.FrameTransform base_link -> camera
  kFoxgloveDoor = 5,         // /ajar/door             foxglove.SceneUpdate (latched)
  kFoxgloveImage = 6,        // /ajar/camera/image     foxglove.CompressedImage (PNG)
  kFoxgloveCalibration = 7,  // /ajar/camera/calibration foxglove.CameraCalibration (latched)
};

// The channels with their JSON Schemas (the schemas of the foxglove.* messages describe the fields
// Ajar sends, as the public foxglove schemas define them).
std::vector<foxglove::Channel> foxglove_channels();

class FoxgloveLive {
 public:
  explicit FoxgloveLive(foxglove::ServerOptions options);
  std::uint16_t listen() { return server_.listen(); }
  void start() { server_.start(); }
  void stop() { server_.stop(); }
  foxglove::ServerStats stats() const { return server_.stats(); }

  bool wants_image() const { return server_.subscribed(kFoxgloveImage); }

  void on_telemetry(const protocol::Telemetry& t);
  void on_event(const protocol::Event& e);
  // The door scene from the daemon's stored measurements (published when they change).
  void on_status(const protocol::Status& s);
  void on_model(const protocol::RobotModel& m);  // the camera's mount (base_link -> camera)
  // One camera frame as PNG (`png`: the file's bytes; null when nobody subscribes), captured at
  // `unix_ns`, and the camera's intrinsics (the calibration, published when they change). The
  // frame thread only.
  void on_image(std::shared_ptr<const std::vector<std::uint8_t>> png, std::uint64_t unix_ns,
                const core::PinholeIntrinsics& intrinsics);

 private:
  foxglove::Server server_;
  std::string last_door_;  // the door scene's entities last sent (publish only on a change)
  std::optional<core::PinholeIntrinsics> last_intrinsics_;  // frame thread
};

// The JSON payloads, for the server's thread and for tests.
std::string foxglove_telemetry_json(const protocol::Telemetry& t);
std::string foxglove_event_json(const protocol::Event& e);
std::string foxglove_odometry_json(const protocol::Telemetry& t, std::uint64_t unix_ns);
std::string foxglove_camera_mount_json(const protocol::RobotModel& m, std::uint64_t unix_ns);
// The door scene (SceneUpdate): `entities_only` gives the part that says whether it changed.
std::string foxglove_door_json(const protocol::Status& s, std::uint64_t unix_ns,
                               bool entities_only = false);
std::string foxglove_image_json(const std::vector<std::uint8_t>& png, std::uint64_t unix_ns);
std::string foxglove_calibration_json(const core::PinholeIntrinsics& k, std::uint64_t unix_ns);

}  // namespace ajar::console
