#include "renderer/scene/texture_decode.h"

#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <jpeglib.h>
// jpeglib.h must come first: jerror.h's codes need its types.
#include <jerror.h>
#include <png.h>
#include <stb_image.h>

#include <algorithm>
#include <csetjmp>
#include <cstring>
#include <exception>
#include <memory>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "renderer/scene/scene_limits.h"

namespace caustica {
namespace {

absl::Status corrupt(absl::string_view name, ImageFormat format, absl::string_view why) {
  return absl::InvalidArgumentError(
      absl::StrCat(name, ": not a readable ", image_format_name(format), " image (", why, ")"));
}

// Refuses a size before anything of that size is allocated.
absl::Status check_size(absl::string_view name, int64_t width, int64_t height, size_t texel_bytes) {
  if (width <= 0 || height <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": has no pixels (", width, " x ", height, ")"));
  }
  if (width > kMaxTextureSide || height > kMaxTextureSide) {
    return absl::ResourceExhaustedError(absl::StrCat(
        name, ": ", width, " x ", height, " pixels exceed the largest side of ", kMaxTextureSide));
  }
  const size_t bytes = size_t(width) * size_t(height) * texel_bytes;
  if (bytes > kMaxTextureDecodedBytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat(name, ": ", width, " x ", height, " pixels would decode to ", bytes >> 20,
                     " MiB, beyond the limit of ", kMaxTextureDecodedBytes >> 20, " MiB"));
  }
  return absl::OkStatus();
}

absl::StatusOr<DecodedImage> decode_png(absl::string_view bytes, absl::string_view name) {
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size())) {
    absl::Status status = corrupt(name, ImageFormat::kPng, image.message);
    png_image_free(&image);
    return status;
  }
  if (absl::Status ok = check_size(name, image.width, image.height, 4); !ok.ok()) {
    png_image_free(&image);
    return ok;
  }
  DecodedImage out;
  out.has_alpha = (image.format & PNG_FORMAT_FLAG_ALPHA) != 0;
  image.format = PNG_FORMAT_RGBA;
  out.width = image.width;
  out.height = image.height;
  out.rgba8.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, out.rgba8.data(), 0, nullptr)) {
    absl::Status status = corrupt(name, ImageFormat::kPng, image.message);
    png_image_free(&image);
    return status;
  }
  return out;
}

struct JpegErrors {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

[[noreturn]] void jpeg_fail(j_common_ptr info) {
  auto* errors = reinterpret_cast<JpegErrors*>(info->err);
  info->err->format_message(info, errors->message);
  std::longjmp(errors->jump, 1);
}

// libjpeg reports data that ends early as a warning and pads the image with grey; a texture that
// is cut short is refused instead. Other warnings (extraneous bytes, say) are what real files
// carry, and pass.
void jpeg_warn(j_common_ptr info, int level) {
  if (level < 0 && info->err->msg_code == JWRN_JPEG_EOF) jpeg_fail(info);
}

absl::StatusOr<DecodedImage> decode_jpeg(absl::string_view bytes, absl::string_view name) {
  jpeg_decompress_struct info;
  JpegErrors errors;
  info.err = jpeg_std_error(&errors.manager);
  errors.manager.error_exit = jpeg_fail;
  errors.manager.emit_message = jpeg_warn;
  // Declared before the jump point, so that a failure leaves nothing of them unreleased.
  DecodedImage out;
  if (setjmp(errors.jump) != 0) {
    jpeg_destroy_decompress(&info);
    return corrupt(name, ImageFormat::kJpeg, errors.message);
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, reinterpret_cast<const unsigned char*>(bytes.data()),
               static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  if (absl::Status status = check_size(name, info.image_width, info.image_height, 4);
      !status.ok()) {
    jpeg_destroy_decompress(&info);
    return status;
  }
  info.out_color_space = JCS_EXT_RGBA;
  jpeg_start_decompress(&info);
  out.width = info.output_width;
  out.height = info.output_height;
  out.rgba8.resize(size_t(out.width) * out.height * 4);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = out.rgba8.data() + size_t(info.output_scanline) * out.width * 4;
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return out;
}

// An OpenEXR file read from memory; reading past the end throws, as a file would.
class ExrMemoryStream : public Imf::IStream {
 public:
  ExrMemoryStream(absl::string_view bytes, const std::string& name)
      : Imf::IStream(name.c_str()), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || pos_ + uint64_t(n) > bytes_.size()) {
      throw std::runtime_error("the file ends early");
    }
    std::memcpy(c, bytes_.data() + pos_, size_t(n));
    pos_ += uint64_t(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }

 private:
  absl::string_view bytes_;
  uint64_t pos_ = 0;
};

absl::StatusOr<DecodedImage> decode_exr(absl::string_view bytes, absl::string_view name) {
  try {
    ExrMemoryStream stream(bytes, std::string(name));
    Imf::RgbaInputFile file(stream, 1);
    const Imath::Box2i window = file.dataWindow();
    const int64_t width = int64_t(window.max.x) - window.min.x + 1;
    const int64_t height = int64_t(window.max.y) - window.min.y + 1;
    if (absl::Status ok = check_size(name, width, height, 16); !ok.ok()) return ok;
    std::vector<Imf::Rgba> pixels(size_t(width) * size_t(height));
    // The frame buffer's origin is the data window's, as OpenEXR addresses pixels by their
    // coordinates.
    file.setFrameBuffer(pixels.data() - window.min.x - window.min.y * width, 1, size_t(width));
    file.readPixels(window.min.y, window.max.y);
    DecodedImage out;
    out.width = uint32_t(width);
    out.height = uint32_t(height);
    out.has_alpha = (file.channels() & Imf::WRITE_A) != 0;
    out.rgba32f.resize(pixels.size() * 4);
    for (size_t i = 0; i < pixels.size(); ++i) {
      out.rgba32f[4 * i + 0] = float(pixels[i].r);
      out.rgba32f[4 * i + 1] = float(pixels[i].g);
      out.rgba32f[4 * i + 2] = float(pixels[i].b);
      out.rgba32f[4 * i + 3] = float(pixels[i].a);
    }
    return out;
  } catch (const std::exception& e) {
    return corrupt(name, ImageFormat::kOpenExr, e.what());
  }
}

// TGA and Radiance HDR through stb_image, with four channels asked for.
absl::StatusOr<DecodedImage> decode_stb(absl::string_view bytes, absl::string_view name,
                                        ImageFormat format) {
  if (bytes.size() > size_t(INT32_MAX)) return corrupt(name, format, "larger than 2 GiB");
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int length = static_cast<int>(bytes.size());
  int width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(data, length, &width, &height, &channels)) {
    return corrupt(name, format, stbi_failure_reason());
  }
  const bool hdr = format == ImageFormat::kRadianceHdr;
  if (absl::Status ok = check_size(name, width, height, hdr ? 16 : 4); !ok.ok()) return ok;
  DecodedImage out;
  if (hdr) {
    std::unique_ptr<float, void (*)(void*)> pixels(
        stbi_loadf_from_memory(data, length, &width, &height, &channels, 4), stbi_image_free);
    if (pixels == nullptr) return corrupt(name, format, stbi_failure_reason());
    out.rgba32f.assign(pixels.get(), pixels.get() + size_t(width) * height * 4);
  } else {
    std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
        stbi_load_from_memory(data, length, &width, &height, &channels, 4), stbi_image_free);
    if (pixels == nullptr) return corrupt(name, format, stbi_failure_reason());
    out.rgba8.assign(pixels.get(), pixels.get() + size_t(width) * height * 4);
  }
  out.width = uint32_t(width);
  out.height = uint32_t(height);
  out.has_alpha = channels == 2 || channels == 4;
  return out;
}

bool starts_with_bytes(absl::string_view bytes, absl::string_view prefix) {
  return bytes.size() >= prefix.size() && bytes.substr(0, prefix.size()) == prefix;
}

}  // namespace

ImageFormat sniff_image_format(absl::string_view bytes) {
  if (starts_with_bytes(bytes, absl::string_view("\x89PNG\r\n\x1a\n", 8))) return ImageFormat::kPng;
  if (starts_with_bytes(bytes, "\xff\xd8\xff")) return ImageFormat::kJpeg;
  if (starts_with_bytes(bytes, "\x76\x2f\x31\x01")) return ImageFormat::kOpenExr;
  if (starts_with_bytes(bytes, "#?RADIANCE") || starts_with_bytes(bytes, "#?RGBE")) {
    return ImageFormat::kRadianceHdr;
  }
  // TGA's 18-byte header: a colour map type of 0 or 1, an image type of (RLE) colour-mapped,
  // true-colour or grey, and a pixel depth TGA defines.
  if (bytes.size() >= 18) {
    const auto u = [&](size_t i) { return static_cast<uint8_t>(bytes[i]); };
    const uint8_t type = u(2) & ~8u;
    const uint8_t depth = u(16);
    if (u(1) <= 1 && type >= 1 && type <= 3 &&
        (depth == 8 || depth == 15 || depth == 16 || depth == 24 || depth == 32)) {
      return ImageFormat::kTga;
    }
  }
  return ImageFormat::kUnknown;
}

const char* image_format_name(ImageFormat format) {
  switch (format) {
    case ImageFormat::kPng:
      return "PNG";
    case ImageFormat::kJpeg:
      return "JPEG";
    case ImageFormat::kOpenExr:
      return "OpenEXR";
    case ImageFormat::kRadianceHdr:
      return "Radiance HDR";
    case ImageFormat::kTga:
      return "TGA";
    case ImageFormat::kUnknown:
      break;
  }
  return "unknown";
}

absl::StatusOr<DecodedImage> decode_image(absl::string_view bytes, absl::string_view name) {
  if (bytes.empty()) return absl::InvalidArgumentError(absl::StrCat(name, ": is empty"));
  if (bytes.size() > kMaxTextureFileBytes) {
    return absl::ResourceExhaustedError(absl::StrCat(name, ": ", bytes.size() >> 20,
                                                     " MiB exceed the largest image file of ",
                                                     kMaxTextureFileBytes >> 20, " MiB"));
  }
  const ImageFormat format = sniff_image_format(bytes);
  switch (format) {
    case ImageFormat::kPng:
      return decode_png(bytes, name);
    case ImageFormat::kJpeg:
      return decode_jpeg(bytes, name);
    case ImageFormat::kOpenExr:
      return decode_exr(bytes, name);
    case ImageFormat::kRadianceHdr:
    case ImageFormat::kTga:
      return decode_stb(bytes, name, format);
    case ImageFormat::kUnknown:
      break;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      name, ": is no image this server reads (PNG, JPEG, OpenEXR, Radiance HDR or TGA)"));
}

absl::Status decode_textures(Scene& scene) {
  std::vector<std::shared_ptr<const DecodedImage>> decoded(scene.textures.size());
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const TextureImage& texture = scene.textures[i];
    if (texture.decoded != nullptr) continue;
    const std::string name = absl::StrCat("textures[", i, "] '", texture.name, "'");
    if (texture.encoded == nullptr) return absl::InvalidArgumentError(name + ": has no bytes");
    absl::StatusOr<DecodedImage> image = decode_image(*texture.encoded, name);
    if (!image.ok()) return image.status();
    decoded[i] = std::make_shared<const DecodedImage>(*std::move(image));
  }
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    if (decoded[i] != nullptr) scene.textures[i].decoded = std::move(decoded[i]);
  }
  return absl::OkStatus();
}

size_t decoded_texture_bytes(const Scene& scene) {
  size_t bytes = 0;
  for (const TextureImage& texture : scene.textures) {
    if (texture.decoded != nullptr) bytes += texture.decoded->bytes();
  }
  return bytes;
}

}  // namespace caustica
