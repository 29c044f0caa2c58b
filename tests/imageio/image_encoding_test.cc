// The image encoders against their reference decoders (libpng, libjpeg, OpenEXR) and by hand
// (PFM), and half floats against known bit patterns and Imath.
#include "imageio/image_encoding.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <gtest/gtest.h>
#include <jpeglib.h>
#include <png.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace caustica {
namespace {

struct Rgba8 {
  uint8_t r, g, b, a;
};

std::span<const uint8_t> bytes_of(const std::vector<Rgba8>& pixels) {
  return {reinterpret_cast<const uint8_t*>(pixels.data()), pixels.size() * 4};
}

TEST(HalfFloat, KnownBitPatterns) {
  struct Case {
    float value;
    uint16_t bits;
  };
  const Case cases[] = {
      {0.0f, 0x0000},
      {-0.0f, 0x8000},
      {1.0f, 0x3c00},
      {-2.0f, 0xc000},
      {0.5f, 0x3800},
      {65504.0f, 0x7bff},  // largest half
      {65519.0f, 0x7bff},  // just below the rounding point to infinity
      {65520.0f, 0x7c00},  // rounds to infinity
      {1e6f, 0x7c00},      // overflow
      {0.1f, 0x2e66},
      {1.0f / 3.0f, 0x3555},
      {std::ldexp(1.0f, -14), 0x0400},             // smallest normal
      {std::ldexp(1.0f, -24), 0x0001},             // smallest subnormal
      {std::ldexp(1.0f, -25), 0x0000},             // half of it: a tie, to even (zero)
      {std::ldexp(1.5f, -25), 0x0001},             // above the tie
      {std::ldexp(3.0f, -25), 0x0002},             // 1.5 units: tie, to even (2)
      {std::ldexp(1023.0f, -24), 0x03ff},          // largest subnormal
      {1.0f + std::ldexp(1.0f, -11), 0x3c00},      // tie between 0x3c00 and 0x3c01: to even
      {1.0f + 3 * std::ldexp(1.0f, -11), 0x3c02},  // tie between 0x3c01 and 0x3c02: to even
      {1.0f + std::ldexp(1.0f, -11) + std::ldexp(1.0f, -20), 0x3c01},  // just above the tie
      {2047.0f / 1024.0f * std::ldexp(1.0f, -15), 0x0400},             // rounds up into the normals
      {std::numeric_limits<float>::infinity(), 0x7c00},
      {-std::numeric_limits<float>::infinity(), 0xfc00},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(float_to_half(c.value), c.bits) << c.value;
  }
  const uint16_t nan = float_to_half(std::numeric_limits<float>::quiet_NaN());
  EXPECT_EQ(nan & 0x7c00, 0x7c00);
  EXPECT_NE(nan & 0x03ff, 0) << "NaN must stay NaN, not become infinity";
}

TEST(HalfFloat, MatchesImathOnRandomFloats) {
  // Imath's conversion rounds to nearest even too; compare across the whole half range and
  // beyond, with bit patterns drawn uniformly so every exponent is hit.
  std::mt19937 random(7);
  std::uniform_int_distribution<uint32_t> exponent(90, 145);
  std::uniform_int_distribution<uint32_t> mantissa(0, 0x7fffff);
  for (int i = 0; i < 200000; ++i) {
    const uint32_t bits = (uint32_t(i & 1) << 31) | (exponent(random) << 23) | mantissa(random);
    const float value = std::bit_cast<float>(bits);
    ASSERT_EQ(float_to_half(value), Imath::half(value).bits()) << value;
  }
}

TEST(ImageEncoding, PngRoundTripsThroughLibpng) {
  const int width = 5, height = 3;
  std::vector<Rgba8> pixels(width * height);
  for (int i = 0; i < width * height; ++i) {
    pixels[i] = {uint8_t(i * 17), uint8_t(255 - i * 3), uint8_t(i * i), 255};
  }
  absl::StatusOr<std::string> png = encode_png(width, height, bytes_of(pixels));
  ASSERT_TRUE(png.ok()) << png.status();
  ASSERT_GT(png->size(), 8u);
  EXPECT_EQ(png->substr(1, 3), "PNG");

  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_memory(&image, png->data(), png->size()));
  EXPECT_EQ(image.width, unsigned(width));
  EXPECT_EQ(image.height, unsigned(height));
  image.format = PNG_FORMAT_RGBA;
  std::vector<Rgba8> decoded(width * height);
  ASSERT_TRUE(png_image_finish_read(&image, nullptr, decoded.data(), 0, nullptr));
  for (int i = 0; i < width * height; ++i) {
    EXPECT_EQ(decoded[i].r, pixels[i].r);
    EXPECT_EQ(decoded[i].g, pixels[i].g);
    EXPECT_EQ(decoded[i].b, pixels[i].b);
    EXPECT_EQ(decoded[i].a, 255);
  }
}

// Reads an EXR from memory, as the client would.
class StringIStream : public Imf::IStream {
 public:
  explicit StringIStream(const std::string& bytes) : Imf::IStream("frame.exr"), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (position_ + n > bytes_.size()) throw std::runtime_error("read past the end");
    std::memcpy(c, bytes_.data() + position_, n);
    position_ += n;
    return position_ < bytes_.size();
  }
  uint64_t tellg() override { return position_; }
  void seekg(uint64_t pos) override { position_ = pos; }

 private:
  const std::string& bytes_;
  size_t position_ = 0;
};

std::vector<float> decode_exr(const std::string& bytes, int* width, int* height,
                              Imf::PixelType* type) {
  StringIStream stream(bytes);
  Imf::InputFile file(stream);
  const Imath::Box2i window = file.header().dataWindow();
  *width = window.max.x - window.min.x + 1;
  *height = window.max.y - window.min.y + 1;
  *type = file.header().channels().findChannel("R")->type;
  std::vector<float> rgba(size_t(*width) * *height * 4);
  Imf::FrameBuffer buffer;
  const char* names[4] = {"R", "G", "B", "A"};
  for (int c = 0; c < 4; ++c) {
    buffer.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(rgba.data() + c),
                                       4 * sizeof(float), 4 * sizeof(float) * *width));
  }
  file.setFrameBuffer(buffer);
  file.readPixels(window.min.y, window.max.y);
  return rgba;
}

TEST(ImageEncoding, ExrRoundTripsThroughOpenExr) {
  const int width = 7, height = 4;
  std::vector<float> linear(width * height * 4);
  for (size_t i = 0; i < linear.size(); ++i) linear[i] = (i % 4 == 3) ? 1.0f : 0.013f * i + 0.25f;

  for (bool half : {false, true}) {
    absl::StatusOr<std::string> exr = encode_exr(width, height, linear, half);
    ASSERT_TRUE(exr.ok()) << exr.status();
    int w = 0, h = 0;
    Imf::PixelType type;
    const std::vector<float> decoded = decode_exr(*exr, &w, &h, &type);
    EXPECT_EQ(w, width);
    EXPECT_EQ(h, height);
    EXPECT_EQ(type, half ? Imf::HALF : Imf::FLOAT);
    for (size_t i = 0; i < linear.size(); ++i) {
      const float expected = half ? float(Imath::half(linear[i])) : linear[i];
      ASSERT_EQ(decoded[i], expected) << "sample " << i << (half ? " (half)" : " (float)");
    }
  }
}

// A smooth image (as renders are), so a JPEG at high quality stays within a few steps.
std::vector<Rgba8> smooth(int width, int height) {
  std::vector<Rgba8> pixels(size_t(width) * height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      pixels[size_t(y) * width + x] = {uint8_t(x * 255 / (width - 1)),
                                       uint8_t(y * 255 / (height - 1)),
                                       uint8_t((x + y) * 255 / (width + height - 2)), 255};
    }
  }
  return pixels;
}

TEST(ImageEncoding, JpegRoundTripsThroughLibjpeg) {
  const int width = 48, height = 32;
  const std::vector<Rgba8> pixels = smooth(width, height);
  absl::StatusOr<std::string> jpeg = encode_jpeg(width, height, bytes_of(pixels), 95);
  ASSERT_TRUE(jpeg.ok()) << jpeg.status();

  jpeg_decompress_struct info;
  jpeg_error_mgr errors;
  info.err = jpeg_std_error(&errors);
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, reinterpret_cast<const unsigned char*>(jpeg->data()), jpeg->size());
  ASSERT_EQ(jpeg_read_header(&info, TRUE), JPEG_HEADER_OK);
  info.out_color_space = JCS_RGB;
  jpeg_start_decompress(&info);
  ASSERT_EQ(int(info.output_width), width);
  ASSERT_EQ(int(info.output_height), height);
  std::vector<uint8_t> rgb(size_t(width) * height * 3);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = rgb.data() + size_t(info.output_scanline) * width * 3;
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  double total_error = 0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const uint8_t expected[3] = {pixels[i].r, pixels[i].g, pixels[i].b};
    for (int c = 0; c < 3; ++c) {
      const int error = std::abs(int(rgb[3 * i + c]) - int(expected[c]));
      ASSERT_LE(error, 12) << "pixel " << i << " channel " << c;
      total_error += error;
    }
  }
  EXPECT_LT(total_error / (pixels.size() * 3), 2.0);
}

// libjpeg-turbo's decode of one JPEG as RGB rows; `height` gets its row count.
std::vector<uint8_t> decode_jpeg_rgb(std::string_view jpeg, int width, int* height) {
  jpeg_decompress_struct info;
  jpeg_error_mgr errors;
  info.err = jpeg_std_error(&errors);
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, reinterpret_cast<const unsigned char*>(jpeg.data()), jpeg.size());
  EXPECT_EQ(jpeg_read_header(&info, TRUE), JPEG_HEADER_OK);
  info.out_color_space = JCS_RGB;
  jpeg_start_decompress(&info);
  EXPECT_EQ(int(info.output_width), width);
  *height = int(info.output_height);
  std::vector<uint8_t> rgb(size_t(width) * info.output_height * 3);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = rgb.data() + size_t(info.output_scanline) * width * 3;
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return rgb;
}

TEST(ImageEncoding, JpegStripsDecodeToTheImage) {
  const int width = 72, height = 100;  // 7 blocks of 16 rows, the last one short
  const std::vector<Rgba8> pixels = smooth(width, height);
  absl::StatusOr<std::string> whole = encode_jpeg(width, height, bytes_of(pixels), 90);
  ASSERT_TRUE(whole.ok()) << whole.status();
  int whole_height = 0;
  const std::vector<uint8_t> whole_rgb = decode_jpeg_rgb(*whole, width, &whole_height);
  for (int strips : {2, 3, 4, 7, 16}) {
    absl::StatusOr<JpegStrips> encoded =
        encode_jpeg_strips(width, height, bytes_of(pixels), 90, strips);
    ASSERT_TRUE(encoded.ok()) << encoded.status();
    const size_t count = std::min(strips, 7);
    ASSERT_EQ(encoded->strip_bytes.size(), count) << strips;
    ASSERT_EQ(encoded->strip_rows.size(), count) << strips;
    std::vector<uint8_t> rgb;
    size_t offset = 0;
    int rows = 0;
    for (size_t i = 0; i < count; ++i) {
      if (i + 1 < count) EXPECT_EQ(encoded->strip_rows[i] % 16, 0u) << strips << " strip " << i;
      const std::string_view strip =
          std::string_view(encoded->data).substr(offset, encoded->strip_bytes[i]);
      offset += encoded->strip_bytes[i];
      ASSERT_GE(strip.size(), 4u);
      EXPECT_EQ(uint8_t(strip[0]), 0xff);
      EXPECT_EQ(uint8_t(strip[1]), 0xd8);
      EXPECT_EQ(uint8_t(strip[strip.size() - 2]), 0xff);
      EXPECT_EQ(uint8_t(strip[strip.size() - 1]), 0xd9);
      int strip_height = 0;
      const std::vector<uint8_t> part = decode_jpeg_rgb(strip, width, &strip_height);
      EXPECT_EQ(strip_height, int(encoded->strip_rows[i]));
      rows += strip_height;
      rgb.insert(rgb.end(), part.begin(), part.end());
    }
    EXPECT_EQ(offset, encoded->data.size());
    ASSERT_EQ(rows, height);
    // Each strip is as close to the pixels as the one JPEG is, and so close to its decode.
    double total_error = 0;
    for (size_t i = 0; i < pixels.size(); ++i) {
      const uint8_t expected[3] = {pixels[i].r, pixels[i].g, pixels[i].b};
      for (int c = 0; c < 3; ++c) {
        const int error = std::abs(int(rgb[3 * i + c]) - int(expected[c]));
        ASSERT_LE(error, 16) << strips << " strips, pixel " << i << " channel " << c;
        EXPECT_LE(std::abs(int(rgb[3 * i + c]) - int(whole_rgb[3 * i + c])), 16);
        total_error += error;
      }
    }
    EXPECT_LT(total_error / (pixels.size() * 3), 2.5) << strips;
  }
}

TEST(ImageEncoding, OneJpegStripIsTheJpeg) {
  const int width = 40, height = 37;
  const std::vector<Rgba8> pixels = smooth(width, height);
  absl::StatusOr<std::string> whole = encode_jpeg(width, height, bytes_of(pixels), 85);
  absl::StatusOr<JpegStrips> one = encode_jpeg_strips(width, height, bytes_of(pixels), 85, 1);
  ASSERT_TRUE(whole.ok() && one.ok());
  EXPECT_EQ(one->data, *whole);
  EXPECT_EQ(one->strip_bytes, std::vector<uint32_t>{uint32_t(whole->size())});
  EXPECT_EQ(one->strip_rows, std::vector<uint32_t>{uint32_t(height)});
}

TEST(ImageEncoding, JpegStripRowsAreEvenWholeBlocks) {
  const std::vector<Rgba8> pixels = smooth(16, 1024);
  absl::StatusOr<JpegStrips> four = encode_jpeg_strips(16, 1024, bytes_of(pixels), 90, 4);
  ASSERT_TRUE(four.ok());
  EXPECT_EQ(four->strip_rows, (std::vector<uint32_t>{256, 256, 256, 256}));
  const std::vector<Rgba8> odd = smooth(16, 1000);
  absl::StatusOr<JpegStrips> uneven = encode_jpeg_strips(16, 1000, bytes_of(odd), 90, 4);
  ASSERT_TRUE(uneven.ok());
  EXPECT_EQ(uneven->strip_rows, (std::vector<uint32_t>{256, 256, 256, 232}));
  const std::vector<Rgba8> short_image = smooth(16, 20);
  absl::StatusOr<JpegStrips> two = encode_jpeg_strips(16, 20, bytes_of(short_image), 90, 16);
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two->strip_rows, (std::vector<uint32_t>{16, 4}));
}

TEST(ImageEncoding, RefusesBadJpegStripCounts) {
  const std::vector<Rgba8> pixels = smooth(16, 16);
  for (int strips : {0, -1, kMaxJpegStrips + 1}) {
    EXPECT_EQ(encode_jpeg_strips(16, 16, bytes_of(pixels), 90, strips).status().code(),
              absl::StatusCode::kInvalidArgument)
        << strips;
  }
  EXPECT_EQ(encode_jpeg_strips(16, 16, bytes_of(pixels), 0, 2).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(encode_jpeg_strips(16, 15, bytes_of(pixels), 90, 2).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ImageEncoding, JpegQualityChangesTheSize) {
  const std::vector<Rgba8> pixels = smooth(64, 64);
  absl::StatusOr<std::string> low = encode_jpeg(64, 64, bytes_of(pixels), 10);
  absl::StatusOr<std::string> high = encode_jpeg(64, 64, bytes_of(pixels), 100);
  ASSERT_TRUE(low.ok() && high.ok());
  EXPECT_LT(low->size(), high->size());
  EXPECT_EQ(encode_jpeg(64, 64, bytes_of(pixels), 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(encode_jpeg(64, 64, bytes_of(pixels), 101).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ImageEncoding, PfmIsColourLittleEndianBottomRowFirst) {
  const int width = 3, height = 2;
  std::vector<float> rgba(width * height * 4);
  for (size_t i = 0; i < rgba.size(); ++i) rgba[i] = 0.5f * i - 1.0f;
  absl::StatusOr<std::string> pfm = encode_pfm(width, height, rgba);
  ASSERT_TRUE(pfm.ok()) << pfm.status();
  const std::string header = "PF\n3 2\n-1.0\n";
  ASSERT_EQ(pfm->substr(0, header.size()), header);
  ASSERT_EQ(pfm->size(), header.size() + width * height * 3 * sizeof(float));
  const char* data = pfm->data() + header.size();
  for (int row = 0; row < height; ++row) {
    const int y = height - 1 - row;  // the file starts at the bottom row
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < 3; ++c) {
        float value;
        std::memcpy(&value, data + ((size_t(row) * width + x) * 3 + c) * sizeof(float),
                    sizeof(float));
        EXPECT_EQ(value, rgba[(size_t(y) * width + x) * 4 + c]) << x << "," << y << " c" << c;
      }
    }
  }
}

TEST(ImageEncoding, RefusesSizesThatDoNotMatchThePixels) {
  const std::vector<Rgba8> pixels(6);
  EXPECT_EQ(encode_png(3, 3, bytes_of(pixels)).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(encode_jpeg(0, 6, bytes_of(pixels), 90).status().code(),
            absl::StatusCode::kInvalidArgument);
  const std::vector<float> floats(10);
  EXPECT_EQ(encode_exr(2, 2, floats, true).status().code(), absl::StatusCode::kInvalidArgument);
  absl::StatusOr<std::string> pfm = encode_pfm(-1, 2, floats);
  EXPECT_EQ(pfm.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(pfm.status().message().find("-1x2"), std::string::npos) << pfm.status().message();
}

}  // namespace
}  // namespace caustica
