// Frames to files: an 8-bit sRGB frame written as PNG keeps its bytes exactly (the decode to
// linear and imageio's re-encode round-trip), a float frame written as EXR keeps its values.
#include "client/frame_image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

namespace caustica::client {
namespace {

std::filesystem::path temp_path(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         (std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" + name);
}

TEST(FrameImage, PngKeepsEveryByteOfAnSrgbFrame) {
  v1::Frame frame;
  frame.set_width(16);
  frame.set_height(16);
  frame.set_pixel_format(v1::RGBA8_SRGB);
  std::string data(16 * 16 * 4, '\0');
  for (size_t i = 0; i < data.size(); ++i) {
    data[i] = static_cast<char>(i % 4 == 3 ? 255 : (i / 4) % 256);  // every value in every channel
  }
  frame.set_data(data);
  const std::filesystem::path path = temp_path("frame.png");
  ASSERT_TRUE(write_frame(frame, path).ok());
  absl::StatusOr<LinearImage> read = read_image(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(read.ok()) << read.status();
  absl::StatusOr<LinearImage> decoded = frame_to_image(frame);
  ASSERT_TRUE(decoded.ok());
  ASSERT_EQ(read->rgba.size(), decoded->rgba.size());
  for (size_t i = 0; i < data.size(); ++i) {
    // Both sides decode the same byte with the same curve; any changed byte shows as a step.
    EXPECT_NEAR(read->rgba[i], decoded->rgba[i], 1e-6) << "value " << i;
  }
  EXPECT_EQ(decoded->rgba[4 * 255], 1.0f);                // byte 255 -> 1
  EXPECT_EQ(decoded->rgba[0], 0.0f);                      // byte 0 -> 0
  EXPECT_NEAR(decoded->rgba[4 * 128], 0.2158605f, 1e-6);  // sRGB 128/255
}

TEST(FrameImage, ExrKeepsFloatValues) {
  v1::Frame frame;
  frame.set_width(3);
  frame.set_height(2);
  frame.set_pixel_format(v1::RGBA32F_LINEAR);
  std::vector<float> values(3 * 2 * 4);
  for (size_t i = 0; i < values.size(); ++i) values[i] = i % 4 == 3 ? 1.0f : 0.125f * i + 3.0f;
  frame.set_data(std::string(reinterpret_cast<const char*>(values.data()), values.size() * 4));
  const std::filesystem::path path = temp_path("frame.exr");
  ASSERT_TRUE(write_frame(frame, path).ok());
  absl::StatusOr<LinearImage> read = read_image(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(read.ok()) << read.status();
  ASSERT_EQ(read->rgba.size(), values.size());
  for (size_t i = 0; i < values.size(); ++i) EXPECT_EQ(read->rgba[i], values[i]) << i;
}

TEST(FrameImage, RefusesDataOfTheWrongSize) {
  v1::Frame frame;
  frame.set_width(2);
  frame.set_height(2);
  frame.set_pixel_format(v1::RGBA32F_LINEAR);
  frame.set_data(std::string(16 * 3, '\0'));
  EXPECT_EQ(frame_to_image(frame).status().code(), absl::StatusCode::kDataLoss);
}

TEST(FrameImage, AsksForTheFormatTheFileNeeds) {
  EXPECT_EQ(frame_format_for("a.exr", 2).pixel_format(), v1::RGBA32F_LINEAR);
  EXPECT_EQ(frame_format_for("a.PFM", 2).pixel_format(), v1::RGBA32F_LINEAR);
  const v1::FrameFormat png = frame_format_for("a.png", 1.5f);
  EXPECT_EQ(png.pixel_format(), v1::RGBA8_SRGB);
  EXPECT_EQ(png.encoding(), v1::RAW);
  EXPECT_EQ(png.exposure_stops(), 1.5f);
}

}  // namespace
}  // namespace caustica::client
