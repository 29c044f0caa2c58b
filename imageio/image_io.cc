#include "imageio/image_io.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace caustica {
namespace {

std::string extension_of(const std::filesystem::path& path) {
  return absl::AsciiStrToLower(path.extension().string());
}

float srgb_encode(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

// PFM (portable float map): "PF", size, a negative scale for little-endian, then RGB float rows
// from the bottom up. Written here because OpenImageIO 2.4's PNM writer only writes 8/16-bit.
absl::Status write_pfm(const std::filesystem::path& path, const LinearImage& image) {
  std::FILE* f = std::fopen(path.string().c_str(), "wb");
  if (f == nullptr)
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": cannot open for writing"));
  std::string header = absl::StrCat("PF\n", image.width, " ", image.height, "\n-1.0\n");
  bool ok = std::fwrite(header.data(), 1, header.size(), f) == header.size();
  std::vector<float> row(size_t(image.width) * 3);
  for (int y = image.height - 1; ok && y >= 0; --y) {
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c)
        row[3 * x + c] = image.rgba[4 * (size_t(y) * image.width + x) + c];
    ok = std::fwrite(row.data(), sizeof(float), row.size(), f) == row.size();
  }
  ok = std::fclose(f) == 0 && ok;
  if (!ok) return absl::InternalError(absl::StrCat(path.string(), ": write failed"));
  return absl::OkStatus();
}

// RGBA `pixels` of type `given` written to `path` as `stored` (8-bit files are sRGB, float ones
// linear).
absl::Status write_with_oiio(const std::filesystem::path& path, int width, int height,
                             OIIO::TypeDesc stored, OIIO::TypeDesc given, const void* pixels) {
  auto out = OIIO::ImageOutput::create(path.string());
  if (!out)
    return absl::InvalidArgumentError(absl::StrCat(
        path.string(), ": no image writer for this extension (", OIIO::geterror(), ")"));
  OIIO::ImageSpec spec(width, height, 4, stored);
  spec.attribute("oiio:ColorSpace", stored == OIIO::TypeDesc::FLOAT ? "linear" : "sRGB");
  // zlib level 3 instead of OpenImageIO's 6: the client writes a PNG per animation frame, and on
  // a 16-core GPU host 24 frames of 256x256 took 686..723 ms at level 6 against 223..234 at 3,
  // for files 8% larger.
  spec.attribute("png:compressionLevel", 3);
  if (!out->open(path.string(), spec) || !out->write_image(given, pixels) || !out->close())
    return absl::InternalError(absl::StrCat(path.string(), ": ", out->geterror()));
  return absl::OkStatus();
}

}  // namespace

bool is_float_format(const std::filesystem::path& path) {
  std::string ext = extension_of(path);
  return ext == ".exr" || ext == ".pfm";
}

absl::Status write_image(const std::filesystem::path& path, const LinearImage& image,
                         float exposure_stops) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != size_t(image.width) * image.height * 4)
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": image has no pixels"));
  const bool linear = is_float_format(path);
  if (extension_of(path) == ".pfm") return write_pfm(path, image);
  const int channels = 4;
  const size_t n = size_t(image.width) * image.height;
  std::vector<float> pixels(n * channels);
  const float scale = std::exp2(exposure_stops);
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < channels; ++c) {
      float v = image.rgba[4 * i + c];
      pixels[i * channels + c] = linear || c == 3 ? v : srgb_encode(v * scale);
    }
  }
  return write_with_oiio(path, image.width, image.height,
                         linear ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8,
                         OIIO::TypeDesc::FLOAT, pixels.data());
}

absl::Status write_srgb8_image(const std::filesystem::path& path, int width, int height,
                               std::span<const uint8_t> rgba) {
  if (width <= 0 || height <= 0 || rgba.size() != size_t(width) * height * 4)
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": image has no pixels"));
  if (is_float_format(path))
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": a float format cannot take 8-bit sRGB pixels"));
  return write_with_oiio(path, width, height, OIIO::TypeDesc::UINT8, OIIO::TypeDesc::UINT8,
                         rgba.data());
}

absl::StatusOr<LinearImage> read_image(const std::filesystem::path& path) {
  auto in = OIIO::ImageInput::open(path.string());
  if (!in) return absl::NotFoundError(absl::StrCat(path.string(), ": ", OIIO::geterror()));
  const OIIO::ImageSpec& spec = in->spec();
  LinearImage image{spec.width, spec.height, {}};
  std::vector<float> pixels(size_t(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data()))
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": ", in->geterror()));
  const bool encoded =
      !(spec.format == OIIO::TypeDesc::FLOAT || spec.format == OIIO::TypeDesc::HALF);
  image.rgba.assign(size_t(spec.width) * spec.height * 4, 1.0f);
  for (size_t i = 0; i < size_t(spec.width) * spec.height; ++i) {
    for (int c = 0; c < std::min(spec.nchannels, 4); ++c) {
      float v = pixels[i * spec.nchannels + c];
      if (encoded && c < 3) v = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
      image.rgba[4 * i + c] = v;
    }
  }
  return image;
}

}  // namespace caustica
