// The live camera: an OpenNI2 RGBD sensor (the paper's ASUS Xtion Pro Live) with depth registered
// to colour (OpenNI2's IMAGE_REGISTRATION_DEPTH_TO_COLOR), 640x480 at 30 Hz. Built only when
// OpenNI2 (Debian: libopenni2-dev) was found at configure time.
#pragma once

#include <memory>
#include <string>

#include "ajar/console/frame.hpp"

namespace ajar::console {

// Opens the sensor at `uri` (empty: the first one found). Null with `error` saying why: no sensor
// plugged in, OpenNI2 failed to initialise, or this build has no OpenNI2.
std::unique_ptr<FrameSource> make_live_source(const std::string& uri, std::string& error);

}  // namespace ajar::console
