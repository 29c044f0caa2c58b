// Image files round-trip through OpenImageIO: float formats exactly, 8-bit formats within one
// code value of the sRGB encoding.
#include "imageio/image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace caustica {
namespace {

LinearImage gradient(int w, int h) {
  LinearImage img{w, h, std::vector<float>(size_t(w) * h * 4)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float* p = &img.rgba[4 * (size_t(y) * w + x)];
      p[0] = float(x) / (w - 1);
      p[1] = float(y) / (h - 1) * 3.0f;  // above 1: clipped in 8-bit, kept in float formats
      p[2] = 0.25f;
      p[3] = 1.0f;
    }
  return img;
}

std::filesystem::path temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("caustica_image_io_test_" + name);
}

TEST(ImageIo, FloatFormatsRoundTripExactly) {
  LinearImage img = gradient(37, 21);
  for (const char* ext : {".exr", ".pfm"}) {
    SCOPED_TRACE(ext);
    auto path = temp_file(std::string("float") + ext);
    absl::Status written = write_image(path, img);
    ASSERT_TRUE(written.ok()) << written;
    absl::StatusOr<LinearImage> back = read_image(path);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_EQ(back->width, 37);
    ASSERT_EQ(back->height, 21);
    for (size_t i = 0; i < img.rgba.size(); ++i)
      ASSERT_EQ(back->rgba[i], img.rgba[i]) << i;  // alpha 1 too
    std::filesystem::remove(path);
  }
}

TEST(ImageIo, PngIsSrgbEncodedAndClipped) {
  LinearImage img = gradient(16, 16);
  auto path = temp_file("tonemapped.png");
  ASSERT_TRUE(write_image(path, img, /*exposure_stops=*/1.0f).ok());
  absl::StatusOr<LinearImage> back = read_image(path);
  ASSERT_TRUE(back.ok()) << back.status();
  for (size_t i = 0; i < img.rgba.size(); i += 4) {
    for (int c = 0; c < 3; ++c) {
      float expected = std::min(1.0f, img.rgba[i + c] * 2.0f);  // one stop of exposure
      // One 8-bit code value near v is at most ~1/255 in sRGB, so a relative bound in linear.
      ASSERT_NEAR(back->rgba[i + c], expected, 0.01f + 0.02f * expected) << i << " " << c;
    }
  }
  std::filesystem::remove(path);
}

TEST(ImageIo, UnknownExtensionAndEmptyImageAreErrors) {
  EXPECT_FALSE(write_image(temp_file("x.notaformat"), gradient(4, 4)).ok());
  EXPECT_EQ(write_image(temp_file("x.png"), LinearImage{}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(read_image(temp_file("missing.exr")).status().code(), absl::StatusCode::kNotFound);
}

// sRGB bytes go into an 8-bit file unchanged; a float format or a wrong size is refused.
TEST(ImageIo, Srgb8PixelsAreWrittenAsTheyAre) {
  const int w = 16, h = 16;
  std::vector<uint8_t> bytes(size_t(w) * h * 4);
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = uint8_t(i % 4 == 3 ? 255 : (i * 7) % 256);
  const std::filesystem::path path = temp_file("bytes.png");
  ASSERT_TRUE(write_srgb8_image(path, w, h, bytes).ok());
  absl::StatusOr<LinearImage> read = read_image(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(read.ok()) << read.status();
  for (size_t i = 0; i < bytes.size(); ++i) {
    const float v = bytes[i] / 255.0f;
    const float expected =
        i % 4 == 3 ? v : (v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f));
    ASSERT_NEAR(read->rgba[i], expected, 1e-6f) << "value " << i;
  }
  EXPECT_EQ(write_srgb8_image(temp_file("bytes.exr"), w, h, bytes).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(write_srgb8_image(temp_file("short.png"), w, h + 1, bytes).code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace caustica
