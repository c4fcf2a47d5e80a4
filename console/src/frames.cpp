// The frame thread: paces the frame source at its rate (0.5 to 60 Hz), gives it the base pose from
// telemetry, encodes PNG messages only while a page is connected (the depth overlay only while one
// asks for it) and hands each frame to the Asio thread, which keeps the last six and sends them.
#include "server_impl.hpp"

#include <algorithm>
#include <cmath>

#include "ajar/console/image_io.hpp"

namespace ajar::console {
namespace {

// Depth colourised for the overlay: near red .. far blue over the sensor's range, holes magenta.
Rgb8Image colourise_depth(const Frame& f) {
  Rgb8Image img{f.intrinsics.width_px, f.intrinsics.height_px, {}};
  img.rgb.resize(f.depth_m.size() * 3);
  for (std::size_t i = 0; i < f.depth_m.size(); ++i) {
    const double d = f.depth_m[i];
    std::array<double, 3> c{255, 0, 255};
    if (d > 0) {
      const double x = std::clamp((d - 0.4) / 3.6, 0.0, 1.0);
      c = {255 * std::clamp(1.5 - 3 * x, 0.0, 1.0),
           255 * std::clamp(1.5 - std::abs(3 * x - 1.5), 0.0, 1.0),
           255 * std::clamp(3 * x - 1.5, 0.0, 1.0)};
    }
    for (std::size_t ch = 0; ch < 3; ++ch)
      img.rgb[i * 3 + ch] = static_cast<std::uint8_t>(c[ch]);
  }
  return img;
}

// Binary frame message: u8 kind (1 colour, 2 depth overlay), u32 sequence (big-endian), PNG.
std::shared_ptr<const std::string> frame_message(std::uint8_t kind, std::uint64_t sequence,
                                                 const std::vector<std::uint8_t>& png) {
  auto msg = std::make_shared<std::string>();
  msg->reserve(png.size() + 5);
  msg->push_back(static_cast<char>(kind));
  const auto seq = static_cast<std::uint32_t>(sequence);
  for (int shift = 24; shift >= 0; shift -= 8) {
    msg->push_back(static_cast<char>((seq >> shift) & 0xFFU));
  }
  msg->append(reinterpret_cast<const char*>(png.data()), png.size());
  return msg;
}

}  // namespace

void ConsoleServer::Impl::frame_loop() {
  const double rate = std::clamp(source->rate_hz(), 0.5, 60.0);
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
  auto next = Clock::now();
  std::string last_error;
  while (!stopping) {
    BasePose p;
    Clock::time_point p_at;
    {
      const std::lock_guard lock(pose_mutex);
      p = pose;
      p_at = pose_at;
    }
    auto entry = std::make_shared<FrameEntry>();
    std::string why;
    if (source->next(p, entry->frame, why)) {
      entry->pose = p;
      entry->captured = Clock::now();
      entry->pose_from = p_at;
      // One PNG for the pages and Foxglove live (only while someone subscribes to the image).
      const bool to_foxglove = foxglove && foxglove->wants_image();
      std::shared_ptr<const std::vector<std::uint8_t>> png;
      if (pages.any_page() || to_foxglove) {
        const auto& k = entry->frame.intrinsics;
        png = std::make_shared<const std::vector<std::uint8_t>>(
            encode_png_rgb8(Rgb8Image{k.width_px, k.height_px, entry->frame.rgb}, 1));
      }
      if (foxglove)
        foxglove->on_image(to_foxglove ? png : nullptr, foxglove::unix_time_ns(),
                           entry->frame.intrinsics);
      if (pages.any_page()) {
        entry->colour = frame_message(1, entry->frame.sequence, *png);
        if (pages.overlay_wanted()) {
          entry->depth = frame_message(2, entry->frame.sequence,
                                       encode_png_rgb8(colourise_depth(entry->frame), 1));
        }
      }
      on_io([this, entry] {
        frames.push_back(entry);
        while (frames.size() > 6)
          frames.pop_front();
        if (!source_error.empty()) {
          source_error.clear();
          mark_dirty();
        }
        // Its age, pose and where each pick's marker is on it, just before the image itself.
        pages.broadcast_frame([&] { return frame_json(*entry); }, entry->colour, entry->depth);
      });
      last_error.clear();
    } else if (why != last_error) {
      last_error = why;
      on_io([this, why] {
        source_error = why;
        add_log("camera: " + why);
        mark_dirty();
      });
    }
    next += period;
    const auto now = Clock::now();
    if (next < now) next = now;
    std::this_thread::sleep_until(next);
  }
}

}  // namespace ajar::console
