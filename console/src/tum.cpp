#include "ajar/console/tum.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "ajar/console/image_io.hpp"

namespace ajar::console {
namespace {

namespace fs = std::filesystem;

bool read_list(const std::string& path, std::vector<std::pair<double, std::string>>& out,
               std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = path + ": cannot open";
    return false;
  }
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t = 0;
    std::string file;
    if (!(fields >> t >> file) || !std::isfinite(t)) {
      error = path + ":" + std::to_string(number) + ": expected 'TIMESTAMP FILE'";
      return false;
    }
    if (file.find("..") != std::string::npos || (!file.empty() && file[0] == '/')) {
      error = path + ":" + std::to_string(number) + ": file must be inside the folder";
      return false;
    }
    out.emplace_back(t, file);
  }
  std::sort(out.begin(), out.end());
  return true;
}

bool read_camera(const std::string& path, TumCamera& camera, std::string& error) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    error = path + ": cannot read: " + e.what();
    return false;
  }
  const auto number = [&](const char* key, double& value, bool required) {
    const auto node = root[key];
    if (!node) {
      if (required) error = path + ": " + key + ": missing";
      return !required;
    }
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      error = path + ": " + key + ": not a number";
      return false;
    }
    return true;
  };
  auto& k = camera.intrinsics;
  double w = 0;
  double h = 0;
  if (!number("fx_px", k.fx_px, true) || !number("fy_px", k.fy_px, true) ||
      !number("cx_px", k.cx_px, true) || !number("cy_px", k.cy_px, true) ||
      !number("width_px", w, true) || !number("height_px", h, true) ||
      !number("depth_scale", camera.depth_scale, true) ||
      !number("rate_hz", camera.rate_hz, false)) {
    return false;
  }
  if (w < 1 || w > 16384 || h < 1 || h > 16384 || w != std::floor(w) || h != std::floor(h)) {
    error = path + ": width_px/height_px: must be whole numbers 1..16384";
    return false;
  }
  k.width_px = static_cast<int>(w);
  k.height_px = static_cast<int>(h);
  if (const auto status = core::check_intrinsics(k); !status) {
    error = path + ": " + status.error().field + ": " + status.error().message;
    return false;
  }
  if (!(camera.depth_scale > 0) || !std::isfinite(camera.depth_scale)) {
    error = path + ": depth_scale: must be > 0";
    return false;
  }
  if (!(camera.rate_hz > 0 && camera.rate_hz <= 120)) {
    error = path + ": rate_hz: must be in (0, 120]";
    return false;
  }
  return true;
}

std::string stamp(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", t);
  return buf;
}

}  // namespace

bool load_tum_sequence(const std::string& folder, TumSequence& out, std::string& error,
                       double max_time_difference_s) {
  out = TumSequence{};
  out.folder = folder;
  if (!read_camera((fs::path(folder) / "camera.yaml").string(), out.camera, error)) return false;
  std::vector<std::pair<double, std::string>> rgb;
  std::vector<std::pair<double, std::string>> depth;
  if (!read_list((fs::path(folder) / "rgb.txt").string(), rgb, error)) return false;
  if (!read_list((fs::path(folder) / "depth.txt").string(), depth, error)) return false;
  for (const auto& [t, file] : rgb) {
    const auto it = std::lower_bound(depth.begin(), depth.end(), std::make_pair(t, std::string()));
    const std::pair<double, std::string>* best = nullptr;
    if (it != depth.end()) best = &*it;
    if (it != depth.begin()) {
      const auto& prev = *std::prev(it);
      if (best == nullptr || std::abs(prev.first - t) < std::abs(best->first - t)) best = &prev;
    }
    if (best != nullptr && std::abs(best->first - t) <= max_time_difference_s) {
      out.frames.push_back({t, file, best->second});
    }
  }
  if (out.frames.empty()) {
    error = folder + ": no colour image has a depth image within " + stamp(max_time_difference_s) +
            " s (rgb.txt: " + std::to_string(rgb.size()) +
            " entries, depth.txt: " + std::to_string(depth.size()) + ")";
    return false;
  }
  return true;
}

bool load_tum_frame(const TumSequence& sequence, std::size_t index, Frame& out,
                    std::string& error) {
  if (index >= sequence.frames.size()) {
    error = sequence.folder + ": no frame " + std::to_string(index);
    return false;
  }
  const auto& entry = sequence.frames[index];
  const auto& k = sequence.camera.intrinsics;
  Rgb8Image rgb;
  Gray16Image depth;
  const auto rgb_path = (fs::path(sequence.folder) / entry.rgb_path).string();
  const auto depth_path = (fs::path(sequence.folder) / entry.depth_path).string();
  if (!read_png_rgb8(rgb_path, rgb, error)) return false;
  if (!read_png_gray16(depth_path, depth, error)) return false;
  if (rgb.width_px != k.width_px || rgb.height_px != k.height_px) {
    error = rgb_path + ": " + std::to_string(rgb.width_px) + "x" + std::to_string(rgb.height_px) +
            " does not match camera.yaml's " + std::to_string(k.width_px) + "x" +
            std::to_string(k.height_px);
    return false;
  }
  if (depth.width_px != k.width_px || depth.height_px != k.height_px) {
    error = depth_path + ": " + std::to_string(depth.width_px) + "x" +
            std::to_string(depth.height_px) + " does not match camera.yaml's " +
            std::to_string(k.width_px) + "x" + std::to_string(k.height_px) +
            " (depth must be registered to colour)";
    return false;
  }
  out.intrinsics = k;
  out.rgb = std::move(rgb.rgb);
  out.depth_m.resize(depth.value.size());
  const double scale = sequence.camera.depth_scale;
  std::transform(depth.value.begin(), depth.value.end(), out.depth_m.begin(),
                 [scale](std::uint16_t v) { return static_cast<float>(v / scale); });
  out.timestamp_s = entry.timestamp_s;
  return true;
}

bool write_tum_frame(const std::string& folder, const Frame& frame, const TumCamera& camera,
                     std::string& error) {
  std::error_code ec;
  fs::create_directories(fs::path(folder) / "rgb", ec);
  fs::create_directories(fs::path(folder) / "depth", ec);
  if (ec) {
    error = folder + ": cannot create: " + ec.message();
    return false;
  }
  const auto& k = frame.intrinsics;
  {
    std::ofstream yaml(fs::path(folder) / "camera.yaml");
    yaml << "# Pinhole intrinsics of the registered colour/depth images (ajar-console).\n"
         << "fx_px: " << k.fx_px << "\nfy_px: " << k.fy_px << "\ncx_px: " << k.cx_px
         << "\ncy_px: " << k.cy_px << "\nwidth_px: " << k.width_px << "\nheight_px: " << k.height_px
         << "\ndepth_scale: " << camera.depth_scale << "\nrate_hz: " << camera.rate_hz << "\n";
    if (!yaml) {
      error = folder + "/camera.yaml: write failed";
      return false;
    }
  }
  const std::string name = stamp(frame.timestamp_s) + ".png";
  Rgb8Image rgb{k.width_px, k.height_px, frame.rgb};
  Gray16Image depth{k.width_px, k.height_px, {}};
  depth.value.reserve(frame.depth_m.size());
  for (const float d : frame.depth_m) {
    const double v = std::round(static_cast<double>(d) * camera.depth_scale);
    depth.value.push_back(std::isfinite(v) && v > 0 && v <= 65535 ? static_cast<std::uint16_t>(v)
                                                                  : std::uint16_t{0});
  }
  if (!write_file((fs::path(folder) / "rgb" / name).string(), encode_png_rgb8(rgb, 9), error) ||
      !write_file((fs::path(folder) / "depth" / name).string(), encode_png_gray16(depth, 9),
                  error)) {
    return false;
  }
  for (const char* list : {"rgb", "depth"}) {
    const auto path = fs::path(folder) / (std::string(list) + ".txt");
    const bool fresh = !fs::exists(path);
    std::ofstream txt(path, std::ios::app);
    if (fresh) txt << "# " << list << " images (TUM RGB-D layout)\n# timestamp filename\n";
    txt << stamp(frame.timestamp_s) << " " << list << "/" << name << "\n";
    if (!txt) {
      error = path.string() + ": write failed";
      return false;
    }
  }
  return true;
}

bool RecordedSource::next(const BasePose& /*pose*/, Frame& out, std::string& why) {
  const std::size_t index = index_;
  index_ = (index_ + 1) % sequence_.frames.size();
  if (!load_tum_frame(sequence_, index, out, why)) return false;
  out.sequence = ++sequence_number_;
  return true;
}

}  // namespace ajar::console
