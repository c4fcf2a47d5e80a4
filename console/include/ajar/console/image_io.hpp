// PNG encode/decode (libpng) for the console: 8-bit RGB colour images and 16-bit grey depth
// images (TUM RGB-D layout). Errors come back as a message naming the file or the problem.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ajar::console {

struct Rgb8Image {
  int width_px = 0;
  int height_px = 0;
  std::vector<std::uint8_t> rgb;  // width x height x 3
};
struct Gray16Image {
  int width_px = 0;
  int height_px = 0;
  std::vector<std::uint16_t> value;  // width x height
};

// Encodes to PNG bytes. compression_level: 0 (none, fastest) .. 9. Empty on failure.
std::vector<std::uint8_t> encode_png_rgb8(const Rgb8Image& image, int compression_level = 1);
std::vector<std::uint8_t> encode_png_gray16(const Gray16Image& image, int compression_level = 6);

// Decodes a PNG file. Colour: any 8-bit PNG (grey, palette and alpha converted to RGB). Depth:
// a 16-bit single-channel PNG. False with `error` naming the file and the problem.
bool read_png_rgb8(const std::string& path, Rgb8Image& out, std::string& error);
bool read_png_gray16(const std::string& path, Gray16Image& out, std::string& error);

// Writes bytes to a file. False with `error` on failure.
bool write_file(const std::string& path, const std::vector<std::uint8_t>& bytes,
                std::string& error);

}  // namespace ajar::console
