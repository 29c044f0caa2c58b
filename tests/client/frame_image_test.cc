// Frames to files without OpenImageIO, read back through OpenImageIO as an independent reader:
// 8-bit frames keep every byte in PNG, float frames keep their values in EXR and PFM, JPEG stays
// close, an encoded frame goes out as it came, and names the CLI cannot write are refused.
#include "client/frame_image.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "imageio/image_io.h"

namespace caustica::client {
namespace {

std::filesystem::path temp_path(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         (std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
          std::to_string(::getpid()) + "_" + name);
}

float srgb_to_linear(uint8_t byte) {
  const float v = byte / 255.0f;
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

v1::Frame srgb8_frame(int width, int height) {
  v1::Frame frame;
  frame.set_width(width);
  frame.set_height(height);
  frame.set_pixel_format(v1::RGBA8_SRGB);
  std::string data(size_t(width) * height * 4, '\0');
  for (size_t i = 0; i < data.size(); ++i) {
    data[i] = static_cast<char>(i % 4 == 3 ? 255 : (i / 4) % 256);  // every value in every channel
  }
  frame.set_data(data);
  return frame;
}

v1::Frame float_frame(int width, int height) {
  v1::Frame frame;
  frame.set_width(width);
  frame.set_height(height);
  frame.set_pixel_format(v1::RGBA32F_LINEAR);
  std::vector<float> values(size_t(width) * height * 4);
  for (size_t i = 0; i < values.size(); ++i) values[i] = i % 4 == 3 ? 1.0f : 0.125f * i + 3.0f;
  frame.set_data(std::string(reinterpret_cast<const char*>(values.data()), values.size() * 4));
  return frame;
}

std::vector<float> floats_of(const v1::Frame& frame) {
  std::vector<float> values(frame.data().size() / 4);
  std::memcpy(values.data(), frame.data().data(), frame.data().size());
  return values;
}

absl::StatusOr<LinearImage> write_and_read(const v1::Frame& frame, const std::string& name) {
  const std::filesystem::path path = temp_path(name);
  if (absl::Status written = write_frame(frame, path); !written.ok()) return written;
  absl::StatusOr<LinearImage> read = read_image(path);
  std::filesystem::remove(path);
  return read;
}

TEST(FrameImage, PngKeepsEveryByteOfAnSrgbFrame) {
  const v1::Frame frame = srgb8_frame(16, 16);
  absl::StatusOr<LinearImage> read = write_and_read(frame, "frame.png");
  ASSERT_TRUE(read.ok()) << read.status();
  ASSERT_EQ(read->rgba.size(), frame.data().size());
  for (size_t i = 0; i < frame.data().size(); ++i) {
    const uint8_t byte = static_cast<uint8_t>(frame.data()[i]);
    const float expected = i % 4 == 3 ? byte / 255.0f : srgb_to_linear(byte);
    // Any changed byte shows as a step of at least 1/255 before the curve.
    EXPECT_NEAR(read->rgba[i], expected, 1e-6) << "value " << i;
  }
}

TEST(FrameImage, JpegStaysCloseToAnSrgbFrame) {
  v1::Frame frame = srgb8_frame(32, 8);
  std::string data = frame.data();
  for (size_t i = 0; i < data.size(); ++i) {  // smooth, as renders are
    data[i] = static_cast<char>(i % 4 == 3 ? 255 : (i / 4 % 32) * 8);
  }
  frame.set_data(data);
  absl::StatusOr<LinearImage> read = write_and_read(frame, "frame.jpg");
  ASSERT_TRUE(read.ok()) << read.status();
  ASSERT_EQ(read->width, 32);
  ASSERT_EQ(read->height, 8);
  double error = 0;
  for (size_t i = 0; i < data.size(); ++i) {
    if (i % 4 == 3) continue;
    error += std::abs(read->rgba[i] - srgb_to_linear(static_cast<uint8_t>(data[i])));
  }
  EXPECT_LT(error / (data.size() * 3 / 4), 0.02);
}

TEST(FrameImage, ExrAndPfmKeepFloatValues) {
  const v1::Frame frame = float_frame(3, 2);
  const std::vector<float> values = floats_of(frame);
  for (const char* name : {"frame.exr", "frame.pfm"}) {
    absl::StatusOr<LinearImage> read = write_and_read(frame, name);
    ASSERT_TRUE(read.ok()) << name << ": " << read.status();
    ASSERT_EQ(read->width, 3);
    ASSERT_EQ(read->height, 2);
    ASSERT_EQ(read->rgba.size(), values.size());
    for (size_t i = 0; i < values.size(); ++i) {
      if (i % 4 == 3) continue;  // PFM has no alpha
      EXPECT_EQ(read->rgba[i], values[i]) << name << " value " << i;
    }
  }
}

TEST(FrameImage, AnEncodedFrameIsWrittenAsItCame) {
  v1::Frame frame;
  frame.set_width(1);
  frame.set_height(1);
  frame.set_encoding(v1::PNG);
  frame.set_data("not checked: the server encoded it");
  absl::StatusOr<std::string> bytes = frame_file_bytes(frame, "a.png");
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(*bytes, frame.data());
  absl::StatusOr<std::string> mismatch = frame_file_bytes(frame, "a.exr");
  EXPECT_EQ(mismatch.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(mismatch.status().message().find("PNG"), std::string::npos) << mismatch.status();
}

TEST(FrameImage, RefusesDataOfTheWrongSize) {
  v1::Frame frame = float_frame(2, 2);
  frame.set_data(std::string(16 * 3, '\0'));
  EXPECT_EQ(frame_file_bytes(frame, "a.exr").status().code(), absl::StatusCode::kDataLoss);
}

TEST(FrameImage, AsksForTheFileTheExtensionNames) {
  const v1::FrameFormat exr = *frame_format_for("a.exr", 2);
  EXPECT_EQ(exr.pixel_format(), v1::RGBA32F_LINEAR);
  EXPECT_EQ(exr.encoding(), v1::EXR);
  const v1::FrameFormat pfm = *frame_format_for("a.PFM", 2);
  EXPECT_EQ(pfm.pixel_format(), v1::RGBA32F_LINEAR);
  EXPECT_EQ(pfm.encoding(), v1::RAW);
  const v1::FrameFormat png = *frame_format_for("a.png", 1.5f);
  EXPECT_EQ(png.pixel_format(), v1::RGBA8_SRGB);
  EXPECT_EQ(png.encoding(), v1::PNG);
  EXPECT_EQ(png.exposure_stops(), 1.5f);
  EXPECT_EQ(frame_format_for("a.JPEG", 0)->encoding(), v1::JPEG);

  absl::StatusOr<v1::FrameFormat> tiff = frame_format_for("out/a.tif", 0);
  EXPECT_EQ(tiff.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(tiff.status().message().find("out/a.tif: cannot write '.tif' files"), std::string::npos)
      << tiff.status();
  EXPECT_EQ(frame_format_for("a", 0).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace caustica::client
