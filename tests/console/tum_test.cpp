// The recorded source: PNG round trips, the TUM RGB-D reader (pairing by time, errors naming the
// file) and the shipped test frames.
#include "ajar/console/tum.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "ajar/console/image_io.hpp"

namespace ajar::console {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("ajar-tum-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

Frame gradient(double t, int w = 8, int h = 6) {
  Frame f;
  f.intrinsics.width_px = w;
  f.intrinsics.height_px = h;
  f.intrinsics.fx_px = f.intrinsics.fy_px = 10;
  f.intrinsics.cx_px = 3.5;
  f.intrinsics.cy_px = 2.5;
  f.timestamp_s = t;
  for (int i = 0; i < w * h; ++i) {
    f.rgb.push_back(static_cast<std::uint8_t>(i * 5));
    f.rgb.push_back(static_cast<std::uint8_t>(255 - i));
    f.rgb.push_back(static_cast<std::uint8_t>(t * 10));
    f.depth_m.push_back(i == 7 ? 0.0F : 0.5F + 0.01F * static_cast<float>(i));
  }
  return f;
}

TEST(Png, Gray16RoundTripKeepsEveryValue) {
  TempDir dir;
  fs::create_directories(dir.path);
  Gray16Image img{3, 2, {0, 1, 255, 256, 40000, 65535}};
  std::string error;
  ASSERT_TRUE(write_file((dir.path / "d.png").string(), encode_png_gray16(img), error)) << error;
  Gray16Image back;
  ASSERT_TRUE(read_png_gray16((dir.path / "d.png").string(), back, error)) << error;
  EXPECT_EQ(back.value, img.value);
  Rgb8Image rgb;
  EXPECT_FALSE(read_png_rgb8((dir.path / "missing.png").string(), rgb, error));
  EXPECT_NE(error.find("missing.png"), std::string::npos);
  // A colour PNG is not a depth image.
  ASSERT_TRUE(write_file((dir.path / "c.png").string(), encode_png_rgb8(Rgb8Image{1, 1, {1, 2, 3}}),
                         error));
  EXPECT_FALSE(read_png_gray16((dir.path / "c.png").string(), back, error));
  EXPECT_NE(error.find("16-bit"), std::string::npos) << error;
}

TEST(Tum, WrittenFramesReadBackPairedByTime) {
  TempDir dir;
  const TumCamera camera{gradient(0).intrinsics, 5000.0, 15.0};
  std::string error;
  for (const double t : {1.0, 1.5, 2.0}) {
    ASSERT_TRUE(write_tum_frame(dir.path.string(), gradient(t), camera, error)) << error;
  }
  TumSequence seq;
  ASSERT_TRUE(load_tum_sequence(dir.path.string(), seq, error)) << error;
  ASSERT_EQ(seq.frames.size(), 3U);
  EXPECT_DOUBLE_EQ(seq.camera.rate_hz, 15.0);
  EXPECT_DOUBLE_EQ(seq.camera.intrinsics.cx_px, 3.5);
  Frame f;
  ASSERT_TRUE(load_tum_frame(seq, 1, f, error)) << error;
  const Frame truth = gradient(1.5);
  EXPECT_EQ(f.rgb, truth.rgb);
  ASSERT_EQ(f.depth_m.size(), truth.depth_m.size());
  for (std::size_t i = 0; i < f.depth_m.size(); ++i) {
    EXPECT_NEAR(f.depth_m[i], truth.depth_m[i], 1.0 / 5000) << i;  // the 16-bit step
  }
  EXPECT_EQ(f.depth_m[7], 0.0F);  // a hole stays a hole
  EXPECT_DOUBLE_EQ(f.timestamp_s, 1.5);
  // The source plays them in a loop.
  RecordedSource source(seq);
  std::string why;
  for (const double t : {1.0, 1.5, 2.0, 1.0}) {
    ASSERT_TRUE(source.next({}, f, why)) << why;
    EXPECT_DOUBLE_EQ(f.timestamp_s, t);
  }
}

TEST(Tum, ColourIsPairedWithTheNearestDepthWithinTheLimit) {
  TempDir dir;
  fs::create_directories(dir.path);
  std::string error;
  const TumCamera camera{gradient(0).intrinsics, 5000.0, 30.0};
  ASSERT_TRUE(write_tum_frame(dir.path.string(), gradient(1.0), camera, error)) << error;
  // Rewrite the lists by hand: the depth of 1.0 is listed at 1.01 (paired), a second colour image
  // at 3.0 has no depth near it (dropped).
  std::ofstream(dir.path / "rgb.txt") << "# rgb\n1.000000 rgb/1.000000.png\n3.0 rgb/1.000000.png\n";
  std::ofstream(dir.path / "depth.txt") << "1.010000 depth/1.000000.png\n";
  TumSequence seq;
  ASSERT_TRUE(load_tum_sequence(dir.path.string(), seq, error)) << error;
  ASSERT_EQ(seq.frames.size(), 1U);
  EXPECT_EQ(seq.frames[0].depth_path, "depth/1.000000.png");
  // Nothing within 0.005 s: an error naming the folder.
  EXPECT_FALSE(load_tum_sequence(dir.path.string(), seq, error, 0.005));
  EXPECT_NE(error.find("no colour image has a depth image"), std::string::npos) << error;
}

TEST(Tum, MistakesAreNamedWithTheFile) {
  TempDir dir;
  fs::create_directories(dir.path);
  std::string error;
  TumSequence seq;
  EXPECT_FALSE(load_tum_sequence(dir.path.string(), seq, error));
  EXPECT_NE(error.find("camera.yaml"), std::string::npos) << error;
  std::ofstream(dir.path / "camera.yaml") << "fx_px: 500\nfy_px: 500\ncx_px: 1\ncy_px: 1\n"
                                             "width_px: 8\nheight_px: 6\n";
  EXPECT_FALSE(load_tum_sequence(dir.path.string(), seq, error));
  EXPECT_NE(error.find("depth_scale: missing"), std::string::npos) << error;
  std::ofstream(dir.path / "camera.yaml", std::ios::app) << "depth_scale: 1000\n";
  std::ofstream(dir.path / "rgb.txt") << "1.0 rgb/a.png\nnot-a-line\n";
  EXPECT_FALSE(load_tum_sequence(dir.path.string(), seq, error));
  EXPECT_NE(error.find("rgb.txt:2"), std::string::npos) << error;
  std::ofstream(dir.path / "rgb.txt") << "1.0 ../../etc/passwd\n";
  EXPECT_FALSE(load_tum_sequence(dir.path.string(), seq, error));
  EXPECT_NE(error.find("inside the folder"), std::string::npos) << error;
  // A depth image of the wrong size (not registered to colour) is refused when loaded.
  const TumCamera camera{gradient(0).intrinsics, 5000.0, 30.0};
  ASSERT_TRUE(write_tum_frame((dir.path / "x").string(), gradient(1.0), camera, error));
  Gray16Image small{2, 2, {1, 2, 3, 4}};
  ASSERT_TRUE(write_file((dir.path / "x" / "depth" / "1.000000.png").string(),
                         encode_png_gray16(small), error));
  ASSERT_TRUE(load_tum_sequence((dir.path / "x").string(), seq, error)) << error;
  Frame f;
  EXPECT_FALSE(load_tum_frame(seq, 0, f, error));
  EXPECT_NE(error.find("registered"), std::string::npos) << error;
}

TEST(Tum, TheShippedRenderedFramesShowTheDoor) {
  TumSequence seq;
  std::string error;
  ASSERT_TRUE(load_tum_sequence(std::string(AJAR_CONSOLE_TEST_DATA) + "/tum-door", seq, error))
      << error;
  ASSERT_GE(seq.frames.size(), 2U);
  for (std::size_t i = 0; i < seq.frames.size(); ++i) {
    Frame f;
    ASSERT_TRUE(load_tum_frame(seq, i, f, error)) << error;
    const auto& k = f.intrinsics;
    // The image centre sees the door (about 1 m away, see data/tum-door/README.md).
    const auto pick = core::pick_point(k, f.depth(), k.cx_px, k.cy_px);
    ASSERT_TRUE(pick.ok()) << pick.error().message;
    EXPECT_GT(pick->depth_m, 0.6);
    EXPECT_LT(pick->depth_m, 1.5);
  }
}

}  // namespace
}  // namespace ajar::console
