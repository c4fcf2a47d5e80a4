// The live OpenNI2 camera. Compiled only when OpenNI2 was found (console/CMakeLists.txt).
#include <OpenNI.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "ajar/console/openni_source.hpp"

namespace ajar::console {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;
constexpr int kFps = 30;
constexpr int kWaitMs = 2000;

std::string last_error(const char* what) {
  return std::string(what) + ": " + openni::OpenNI::getExtendedError();
}

class OpenNiSource final : public FrameSource {
 public:
  bool open(const std::string& uri, std::string& error) {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) {
      error = last_error("OpenNI2 failed to initialise");
      return false;
    }
    initialised_ = true;
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    if (devices.getSize() == 0) {
      error =
          "no OpenNI2 sensor is plugged in (ASUS Xtion / PrimeSense / Kinect-class): plug one in "
          "and restart, or use --source sim / --source recorded";
      return false;
    }
    uri_ = uri.empty() ? devices[0].getUri() : uri;
    if (device_.open(uri.empty() ? openni::ANY_DEVICE : uri.c_str()) != openni::STATUS_OK) {
      error = last_error(("cannot open the sensor " + uri_).c_str());
      return false;
    }
    if (depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK ||
        colour_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK) {
      error = last_error("the sensor has no depth or no colour stream");
      return false;
    }
    openni::VideoMode mode;
    mode.setResolution(kWidth, kHeight);
    mode.setFps(kFps);
    mode.setPixelFormat(openni::PIXEL_FORMAT_DEPTH_1_MM);
    if (depth_.setVideoMode(mode) != openni::STATUS_OK) {
      error = last_error("depth 640x480 @ 30 Hz in millimetres not supported");
      return false;
    }
    mode.setPixelFormat(openni::PIXEL_FORMAT_RGB888);
    if (colour_.setVideoMode(mode) != openni::STATUS_OK) {
      error = last_error("colour 640x480 @ 30 Hz RGB888 not supported");
      return false;
    }
    // The paper: "we align the depth information with respect to the color images".
    if (!device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) ||
        device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) !=
            openni::STATUS_OK) {
      error = last_error("the sensor cannot register depth to colour");
      return false;
    }
    device_.setDepthColorSyncEnabled(true);
    if (depth_.start() != openni::STATUS_OK || colour_.start() != openni::STATUS_OK) {
      error = last_error("cannot start the streams");
      return false;
    }
    // Registered depth shares the colour camera's intrinsics: from its field of view.
    const double hfov = colour_.getHorizontalFieldOfView();
    const double vfov = colour_.getVerticalFieldOfView();
    intrinsics_.width_px = kWidth;
    intrinsics_.height_px = kHeight;
    intrinsics_.fx_px = kWidth / (2.0 * std::tan(hfov / 2.0));
    intrinsics_.fy_px = kHeight / (2.0 * std::tan(vfov / 2.0));
    intrinsics_.cx_px = (kWidth - 1) / 2.0;
    intrinsics_.cy_px = (kHeight - 1) / 2.0;
    return true;
  }

  ~OpenNiSource() override {
    depth_.stop();
    colour_.stop();
    depth_.destroy();
    colour_.destroy();
    device_.close();
    if (initialised_) openni::OpenNI::shutdown();
  }

  std::string describe() const override { return "live: OpenNI2 " + uri_; }
  double rate_hz() const override { return kFps; }

  bool next(const BasePose& /*pose*/, Frame& out, std::string& why) override {
    openni::VideoFrameRef depth_frame;
    openni::VideoFrameRef colour_frame;
    for (openni::VideoStream* stream : {&depth_, &colour_}) {
      int ready = -1;
      if (openni::OpenNI::waitForAnyStream(&stream, 1, &ready, kWaitMs) != openni::STATUS_OK) {
        why = "the sensor sent no frame for 2 s (unplugged?)";
        return false;
      }
    }
    if (depth_.readFrame(&depth_frame) != openni::STATUS_OK ||
        colour_.readFrame(&colour_frame) != openni::STATUS_OK) {
      why = last_error("reading a frame failed");
      return false;
    }
    if (depth_frame.getWidth() != kWidth || depth_frame.getHeight() != kHeight ||
        colour_frame.getWidth() != kWidth || colour_frame.getHeight() != kHeight) {
      why = "the sensor sent a frame of an unexpected size";
      return false;
    }
    out.intrinsics = intrinsics_;
    const auto n = static_cast<std::size_t>(kWidth) * kHeight;
    out.rgb.resize(n * 3);
    out.depth_m.resize(n);
    const auto* rgb = static_cast<const std::uint8_t*>(colour_frame.getData());
    const auto* mm = static_cast<const std::uint8_t*>(depth_frame.getData());
    for (int y = 0; y < kHeight; ++y) {
      std::memcpy(out.rgb.data() + static_cast<std::size_t>(y) * kWidth * 3,
                  rgb + static_cast<std::size_t>(y) *
                            static_cast<std::size_t>(colour_frame.getStrideInBytes()),
                  static_cast<std::size_t>(kWidth) * 3);
      const auto* row = mm + static_cast<std::size_t>(y) *
                                 static_cast<std::size_t>(depth_frame.getStrideInBytes());
      for (int x = 0; x < kWidth; ++x) {
        std::uint16_t v = 0;
        std::memcpy(&v, row + static_cast<std::size_t>(x) * 2, 2);
        out.depth_m[static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x)] =
            static_cast<float>(v) * 0.001F;
      }
    }
    out.sequence = ++sequence_;
    out.timestamp_s = static_cast<double>(colour_frame.getTimestamp()) * 1e-6;
    return true;
  }

 private:
  bool initialised_ = false;
  std::string uri_;
  openni::Device device_;
  openni::VideoStream depth_;
  openni::VideoStream colour_;
  core::PinholeIntrinsics intrinsics_;
  std::uint64_t sequence_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> make_openni_source(const std::string& uri, std::string& error) {
  auto source = std::make_unique<OpenNiSource>();
  if (!source->open(uri, error)) return nullptr;
  return source;
}

}  // namespace ajar::console
