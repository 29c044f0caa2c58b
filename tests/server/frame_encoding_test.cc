// Frame formats: half floats against known bit patterns and Imath, PNG and EXR round trips
// through their reference decoders, format validation and frame splitting.
#include "server/frame_encoding.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <gtest/gtest.h>
#include <png.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace caustica::server {
namespace {

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

TEST(FrameFormat, DefaultsAndRefusedCombinations) {
  v1::FrameFormat format;
  absl::StatusOr<FrameSpec> spec = parse_frame_format(format, "format");
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->pixel_format, v1::RGBA8_SRGB);
  EXPECT_EQ(spec->encoding, v1::RAW);

  format.set_pixel_format(v1::RGBA32F_LINEAR);
  format.set_encoding(v1::PNG);
  spec = parse_frame_format(format, "format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("format.encoding"), std::string::npos)
      << spec.status().message();

  format.set_pixel_format(v1::RGBA8_SRGB);
  format.set_encoding(v1::EXR);
  spec = parse_frame_format(format, "format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("format.encoding"), std::string::npos);

  format.set_pixel_format(static_cast<v1::PixelFormat>(42));
  format.set_encoding(v1::RAW);
  spec = parse_frame_format(format, "format");
  EXPECT_NE(spec.status().message().find("format.pixel_format"), std::string::npos);

  format.set_pixel_format(v1::RGBA16F_LINEAR);
  format.set_encoding(v1::EXR);
  EXPECT_TRUE(parse_frame_format(format, "format").ok());
}

TEST(FrameEncoding, RawHalfIsLittleEndianHalves) {
  const std::vector<float> linear = {1.0f, 0.5f, -2.0f, 65504.0f};
  absl::StatusOr<std::string> raw =
      encode_frame({v1::RGBA16F_LINEAR, v1::RAW, 0}, 1, 1, {}, linear);
  ASSERT_TRUE(raw.ok());
  const std::string expected("\x00\x3c\x00\x38\x00\xc0\xff\x7b", 8);
  EXPECT_EQ(*raw, expected);
}

TEST(FrameEncoding, PngRoundTripsThroughLibpng) {
  const int width = 5, height = 3;
  std::vector<Rgba8> pixels(width * height);
  for (int i = 0; i < width * height; ++i) {
    pixels[i] = {uint8_t(i * 17), uint8_t(255 - i * 3), uint8_t(i * i), 255};
  }
  absl::StatusOr<std::string> png = encode_png(width, height, pixels);
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

TEST(FrameEncoding, ExrRoundTripsThroughOpenExr) {
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

TEST(FrameSplitting, PiecesCoverTheFrameInOrder) {
  v1::Frame header;
  header.set_frame_number(3);
  header.set_width(9);
  std::string data(10, '\0');
  for (int i = 0; i < 10; ++i) data[i] = char('a' + i);

  const std::vector<v1::Frame> pieces = split_frame(header, data, 4);
  ASSERT_EQ(pieces.size(), 3u);
  const uint64_t offsets[] = {0, 4, 8};
  const char* contents[] = {"abcd", "efgh", "ij"};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(pieces[i].frame_number(), 3u);
    EXPECT_EQ(pieces[i].width(), 9u);
    EXPECT_EQ(pieces[i].data_size(), 10u);
    EXPECT_EQ(pieces[i].data_offset(), offsets[i]);
    EXPECT_EQ(pieces[i].data(), contents[i]);
    EXPECT_EQ(pieces[i].last_chunk(), i == 2);
  }

  const std::vector<v1::Frame> whole = split_frame(header, data, 10);
  ASSERT_EQ(whole.size(), 1u);
  EXPECT_EQ(whole[0].data(), data);
  EXPECT_TRUE(whole[0].last_chunk());

  const std::vector<v1::Frame> empty = split_frame(header, "", 4);
  ASSERT_EQ(empty.size(), 1u);
  EXPECT_EQ(empty[0].data_size(), 0u);
  EXPECT_TRUE(empty[0].last_chunk());
}

}  // namespace
}  // namespace caustica::server
