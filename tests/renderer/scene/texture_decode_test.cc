// Texture images decoded as the server decodes an upload's: files made by other tools (the glTF
// sample's PNG, an OBJ model's JPEGs) against stb_image as an independent decoder, small files
// written here byte by byte in TGA and Radiance HDR, an OpenEXR file written by OpenEXR, and every
// format cut short or damaged refused by name.
#include "renderer/scene/texture_decode.h"

#include <OpenEXR/ImfRgbaFile.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stb_image.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "renderer/scene/scene_limits.h"

namespace caustica {
namespace {

using testing::HasSubstr;

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string thirdparty(const char* name) {
  return read_bytes(std::filesystem::path(CAUSTICA_TEST_DATA) / "scene/thirdparty" / name);
}

// stb_image's 8-bit RGBA of `bytes`, the reference the libraries' decodes are held to.
std::vector<uint8_t> stb_rgba(const std::string& bytes, int* width, int* height) {
  int channels = 0;
  stbi_uc* pixels =
      stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()),
                            static_cast<int>(bytes.size()), width, height, &channels, 4);
  if (pixels == nullptr) return {};
  std::vector<uint8_t> out(pixels, pixels + size_t(*width) * size_t(*height) * 4);
  stbi_image_free(pixels);
  return out;
}

void expect_refused(const std::string& bytes, const std::string& message) {
  const absl::StatusOr<DecodedImage> image = decode_image(bytes, "broken.img");
  ASSERT_FALSE(image.ok()) << message;
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument) << image.status();
  EXPECT_THAT(std::string(image.status().message()), HasSubstr("broken.img: "));
  EXPECT_THAT(std::string(image.status().message()), HasSubstr(message));
}

TEST(TextureDecode, ThePngOfTheGltfSampleMatchesStbImage) {
  const std::string png = thirdparty("gltf2/BoxTextured/CesiumLogoFlat.png");
  ASSERT_EQ(sniff_image_format(png), ImageFormat::kPng);
  const absl::StatusOr<DecodedImage> image = decode_image(png, "CesiumLogoFlat.png");
  ASSERT_TRUE(image.ok()) << image.status();
  // The IHDR chunk says 211 x 211, 8-bit RGB; the decode adds an opaque alpha.
  EXPECT_EQ(image->width, 211u);
  EXPECT_EQ(image->height, 211u);
  EXPECT_FALSE(image->is_float());
  int width = 0, height = 0;
  const std::vector<uint8_t> reference = stb_rgba(png, &width, &height);
  ASSERT_EQ(reference.size(), image->rgba8.size());
  EXPECT_EQ(image->rgba8, reference);
  for (size_t i = 3; i < image->rgba8.size(); i += 4) ASSERT_EQ(image->rgba8[i], 255);
  EXPECT_FALSE(image->has_alpha);
}

TEST(TextureDecode, APngWithAlphaSaysSoAndKeepsItsAlphaAsStbImageReadsIt) {
  // ClearCoatTest's PartialCoating_Alpha.png: IHDR colour type 6 (RGBA), coverage in alpha; its
  // PartialCoating.png beside it is type 2 (RGB).
  const std::string png = thirdparty("gltf2/ClearCoat/PartialCoating_Alpha.png");
  const absl::StatusOr<DecodedImage> image = decode_image(png, "PartialCoating_Alpha.png");
  ASSERT_TRUE(image.ok()) << image.status();
  EXPECT_TRUE(image->has_alpha);
  int width = 0, height = 0;
  EXPECT_EQ(image->rgba8, stb_rgba(png, &width, &height));
  size_t clear = 0, covered = 0;
  for (size_t i = 3; i < image->rgba8.size(); i += 4) {
    clear += image->rgba8[i] < 128;
    covered += image->rgba8[i] >= 128;
  }
  EXPECT_GT(clear, 0u);
  EXPECT_GT(covered, 0u);
  const absl::StatusOr<DecodedImage> rgb =
      decode_image(thirdparty("gltf2/ClearCoat/PartialCoating.png"), "PartialCoating.png");
  ASSERT_TRUE(rgb.ok()) << rgb.status();
  EXPECT_FALSE(rgb->has_alpha);
}

TEST(TextureDecode, TheJpegsOfAnObjModelMatchStbImageWithinRounding) {
  for (const char* name : {"obj/spider/SpiderTex.jpg", "obj/spider/drkwood2.jpg"}) {
    const std::string jpeg = thirdparty(name);
    ASSERT_EQ(sniff_image_format(jpeg), ImageFormat::kJpeg) << name;
    const absl::StatusOr<DecodedImage> image = decode_image(jpeg, name);
    ASSERT_TRUE(image.ok()) << image.status();
    int width = 0, height = 0;
    const std::vector<uint8_t> reference = stb_rgba(jpeg, &width, &height);
    ASSERT_EQ(image->width, uint32_t(width)) << name;
    ASSERT_EQ(image->height, uint32_t(height)) << name;
    ASSERT_EQ(reference.size(), image->rgba8.size());
    // Two JPEG decoders differ in their IDCT and chroma upsampling by a few levels at most.
    double total = 0;
    int worst = 0;
    for (size_t i = 0; i < reference.size(); ++i) {
      const int d = std::abs(int(reference[i]) - int(image->rgba8[i]));
      total += d;
      worst = std::max(worst, d);
    }
    EXPECT_LT(total / double(reference.size()), 1.0) << name;
    EXPECT_LE(worst, 48) << name;
  }
}

// A 2 x 2 uncompressed true-colour TGA, bottom row first as TGA stores it, BGR.
std::string tga_2x2() {
  std::string t(18, '\0');
  t[2] = 2;  // true colour
  t[12] = 2;
  t[14] = 2;
  t[16] = 24;
  const unsigned char pixels[] = {/* bottom */ 255, 0, 0,   0,  255, 0,
                                  /* top */ 0,      0, 255, 10, 20,  30};
  t.append(reinterpret_cast<const char*>(pixels), sizeof(pixels));
  return t;
}

TEST(TextureDecode, ATgaWrittenByHandReadsTopRowFirst) {
  const std::string tga = tga_2x2();
  ASSERT_EQ(sniff_image_format(tga), ImageFormat::kTga);
  const absl::StatusOr<DecodedImage> image = decode_image(tga, "hand.tga");
  ASSERT_TRUE(image.ok()) << image.status();
  ASSERT_EQ(image->width, 2u);
  ASSERT_EQ(image->height, 2u);
  const std::vector<uint8_t> expected = {
      255, 0, 0,   255, 30, 20,  10, 255,   // top: red, (30,20,10)
      0,   0, 255, 255, 0,  255, 0,  255};  // bottom: blue, green
  EXPECT_EQ(image->rgba8, expected);
}

TEST(TextureDecode, ARadianceHdrWrittenByHandDecodesItsSharedExponent) {
  // Flat RGBE pixels (a width below 8 is never run-length encoded): mantissas m and exponent e
  // give m * 2^(e - 136).
  std::string hdr = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n";
  const unsigned char pixels[] = {128, 64, 32, 129, 200, 100, 0, 140};
  hdr.append(reinterpret_cast<const char*>(pixels), sizeof(pixels));
  ASSERT_EQ(sniff_image_format(hdr), ImageFormat::kRadianceHdr);
  const absl::StatusOr<DecodedImage> image = decode_image(hdr, "sky.hdr");
  ASSERT_TRUE(image.ok()) << image.status();
  ASSERT_TRUE(image->is_float());
  ASSERT_EQ(image->width, 2u);
  ASSERT_EQ(image->height, 1u);
  const std::vector<float> expected = {1.0f,        0.5f,        0.25f, 1.0f,
                                       200.0f * 16, 100.0f * 16, 0.0f,  1.0f};
  ASSERT_EQ(image->rgba32f.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_FLOAT_EQ(image->rgba32f[i], expected[i]);
}

TEST(TextureDecode, AnOpenExrFileKeepsItsHalfValues) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("caustica-texture-" + std::to_string(getpid()) + ".exr");
  const Imf::Rgba pixels[] = {{0.5f, 2.0f, 100.0f, 1.0f}, {0.0f, 0.25f, 4096.0f, 0.5f}};
  {
    Imf::RgbaOutputFile file(path.c_str(), 2, 1, Imf::WRITE_RGBA);
    file.setFrameBuffer(pixels, 1, 2);
    file.writePixels(1);
  }
  const std::string exr = read_bytes(path);
  std::filesystem::remove(path);
  ASSERT_EQ(sniff_image_format(exr), ImageFormat::kOpenExr);
  const absl::StatusOr<DecodedImage> image = decode_image(exr, "sky.exr");
  ASSERT_TRUE(image.ok()) << image.status();
  ASSERT_EQ(image->width, 2u);
  ASSERT_EQ(image->height, 1u);
  const std::vector<float> expected = {0.5f, 2.0f, 100.0f, 1.0f, 0.0f, 0.25f, 4096.0f, 0.5f};
  EXPECT_EQ(image->rgba32f, expected);
  expect_refused(exr.substr(0, exr.size() - 6), "not a readable OpenEXR image");
}

TEST(TextureDecode, FilesCutShortOrDamagedAreRefusedByName) {
  const std::string png = thirdparty("gltf2/BoxTextured/CesiumLogoFlat.png");
  expect_refused(png.substr(0, png.size() / 2), "not a readable PNG image");
  std::string damaged = png;
  for (size_t i = 100; i < 200; ++i) damaged[i] = char(damaged[i] ^ 0x5a);
  expect_refused(damaged, "not a readable PNG image");
  const std::string jpeg = thirdparty("obj/spider/SpiderTex.jpg");
  expect_refused(jpeg.substr(0, jpeg.size() / 2), "not a readable JPEG image");
  expect_refused(jpeg.substr(0, 40), "not a readable JPEG image");
  expect_refused("#?RADIANCE\nFORMAT=48-bit_xyz\n\n-Y 1 +X 2\n12345678",
                 "not a readable Radiance HDR image");
  expect_refused("GIF89a and more bytes than that", "is no image this server reads");
  expect_refused(std::string(), "is empty");
}

TEST(TextureDecode, ASideBeyondTheLimitIsRefusedBeforeItsPixelsAreAllocated) {
  std::string tga = tga_2x2();
  const uint32_t wide = kMaxTextureSide + 1;
  tga[12] = char(wide & 0xff);
  tga[13] = char(wide >> 8);
  const absl::StatusOr<DecodedImage> image = decode_image(tga, "wide.tga");
  EXPECT_EQ(image.status().code(), absl::StatusCode::kResourceExhausted) << image.status();
  EXPECT_THAT(std::string(image.status().message()),
              HasSubstr("wide.tga: " + std::to_string(wide) + " x 2 pixels exceed"));
}

TEST(TextureDecode, DecodeTexturesNamesTheOneThatFailsAndChangesNothing) {
  Scene scene;
  scene.textures.push_back(
      {"logo.png",
       std::make_shared<const std::string>(thirdparty("gltf2/BoxTextured/CesiumLogoFlat.png")),
       nullptr});
  scene.textures.push_back(
      {"bad.png", std::make_shared<const std::string>("\x89PNG\r\n junk"), nullptr});
  const absl::Status status = decode_textures(scene);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(status.message()), HasSubstr("textures[1] 'bad.png': "));
  EXPECT_EQ(scene.textures[0].decoded, nullptr);
  scene.textures.pop_back();
  ASSERT_TRUE(decode_textures(scene).ok());
  ASSERT_NE(scene.textures[0].decoded, nullptr);
  EXPECT_EQ(decoded_texture_bytes(scene), 211u * 211u * 4u);
}

}  // namespace
}  // namespace caustica
