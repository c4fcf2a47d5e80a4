#include "ajar/console/image_io.hpp"

#include <png.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>

namespace ajar::console {
namespace {

void append_bytes(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + length);
}
void flush_nothing(png_structp /*png*/) {}

struct WriteGuard {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~WriteGuard() { png_destroy_write_struct(&png, &info); }
};
struct ReadGuard {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~ReadGuard() { png_destroy_read_struct(&png, &info, nullptr); }
};

std::vector<std::uint8_t> encode(int width, int height, int bit_depth, int colour_type,
                                 int channels, const std::uint8_t* rows, int level) {
  std::vector<std::uint8_t> out;
  WriteGuard g;
  g.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (g.png == nullptr) return {};
  g.info = png_create_info_struct(g.png);
  if (g.info == nullptr) return {};
  // libpng reports errors by longjmp; nothing with a destructor lives between here and the end.
  if (setjmp(png_jmpbuf(g.png))) return {};  // NOLINT: libpng's error model
  png_set_write_fn(g.png, &out, append_bytes, flush_nothing);
  png_set_compression_level(g.png, level);
  png_set_filter(g.png, 0, level <= 1 ? PNG_FILTER_NONE : PNG_ALL_FILTERS);
  png_set_IHDR(g.png, g.info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               bit_depth, colour_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(g.png, g.info);
  if (bit_depth == 16) png_set_swap(g.png);  // host little-endian samples -> PNG big-endian
  const auto stride = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels) *
                      static_cast<std::size_t>(bit_depth / 8);
  for (int y = 0; y < height; ++y) {
    // libpng's API takes a non-const row pointer but only reads it.
    png_write_row(g.png, const_cast<png_bytep>(rows + stride * static_cast<std::size_t>(y)));
  }
  png_write_end(g.png, nullptr);
  return out;
}

struct File {
  std::FILE* f = nullptr;
  ~File() {
    if (f != nullptr) std::fclose(f);
  }
};

// Reads a PNG into rows of the requested layout after libpng's transformations.
bool decode(const std::string& path, bool want16, int& width, int& height,
            std::vector<std::uint8_t>& bytes, std::string& error) {
  File file;
  file.f = std::fopen(path.c_str(), "rb");
  if (file.f == nullptr) {
    error = path + ": cannot open: " + std::strerror(errno);
    return false;
  }
  std::uint8_t sig[8] = {};
  if (std::fread(sig, 1, 8, file.f) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
    error = path + ": not a PNG file";
    return false;
  }
  ReadGuard g;
  g.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (g.png == nullptr) {
    error = path + ": out of memory";
    return false;
  }
  g.info = png_create_info_struct(g.png);
  if (g.info == nullptr) {
    error = path + ": out of memory";
    return false;
  }
  if (setjmp(png_jmpbuf(g.png))) {  // NOLINT: libpng's error model
    error = path + ": corrupt PNG";
    return false;
  }
  png_init_io(g.png, file.f);
  png_set_sig_bytes(g.png, 8);
  png_read_info(g.png, g.info);
  const auto w = png_get_image_width(g.png, g.info);
  const auto h = png_get_image_height(g.png, g.info);
  const int depth = png_get_bit_depth(g.png, g.info);
  const int type = png_get_color_type(g.png, g.info);
  if (w == 0 || h == 0 || w > 16384 || h > 16384) {
    error = path + ": image size out of range";
    return false;
  }
  if (want16) {
    if (depth != 16 || type != PNG_COLOR_TYPE_GRAY) {
      error = path + ": a depth image must be a 16-bit single-channel PNG (bit depth " +
              std::to_string(depth) + ", colour type " + std::to_string(type) + ")";
      return false;
    }
    png_set_swap(g.png);
  } else {
    if (depth == 16) png_set_strip_16(g.png);
    if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(g.png);
    if (type == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(g.png);
    if (type == PNG_COLOR_TYPE_GRAY || type == PNG_COLOR_TYPE_GRAY_ALPHA) {
      png_set_gray_to_rgb(g.png);
    }
    png_set_strip_alpha(g.png);
  }
  png_read_update_info(g.png, g.info);
  const std::size_t stride = png_get_rowbytes(g.png, g.info);
  const std::size_t expected = static_cast<std::size_t>(w) * (want16 ? 2U : 3U);
  if (stride != expected) {
    error = path + ": unexpected PNG layout";
    return false;
  }
  bytes.assign(stride * h, 0);
  for (png_uint_32 y = 0; y < h; ++y)
    png_read_row(g.png, bytes.data() + stride * y, nullptr);
  png_read_end(g.png, nullptr);
  width = static_cast<int>(w);
  height = static_cast<int>(h);
  return true;
}

}  // namespace

std::vector<std::uint8_t> encode_png_rgb8(const Rgb8Image& image, int compression_level) {
  if (image.rgb.size() !=
      static_cast<std::size_t>(image.width_px) * static_cast<std::size_t>(image.height_px) * 3U) {
    return {};
  }
  return encode(image.width_px, image.height_px, 8, PNG_COLOR_TYPE_RGB, 3, image.rgb.data(),
                compression_level);
}

std::vector<std::uint8_t> encode_png_gray16(const Gray16Image& image, int compression_level) {
  if (image.value.size() !=
      static_cast<std::size_t>(image.width_px) * static_cast<std::size_t>(image.height_px)) {
    return {};
  }
  std::vector<std::uint8_t> bytes(image.value.size() * 2);
  std::memcpy(bytes.data(), image.value.data(), bytes.size());
  return encode(image.width_px, image.height_px, 16, PNG_COLOR_TYPE_GRAY, 1, bytes.data(),
                compression_level);
}

bool read_png_rgb8(const std::string& path, Rgb8Image& out, std::string& error) {
  return decode(path, false, out.width_px, out.height_px, out.rgb, error);
}

bool read_png_gray16(const std::string& path, Gray16Image& out, std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!decode(path, true, out.width_px, out.height_px, bytes, error)) return false;
  out.value.resize(bytes.size() / 2);
  std::memcpy(out.value.data(), bytes.data(), bytes.size());
  return true;
}

bool write_file(const std::string& path, const std::vector<std::uint8_t>& bytes,
                std::string& error) {
  std::ofstream f(path, std::ios::binary);
  if (!f) {
    error = path + ": cannot create";
    return false;
  }
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) {
    error = path + ": write failed";
    return false;
  }
  return true;
}

}  // namespace ajar::console
