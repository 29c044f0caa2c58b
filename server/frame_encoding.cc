#include "server/frame_encoding.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>
#include <png.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <exception>

#include "absl/strings/str_cat.h"

namespace caustica::server {
namespace {

// RAW frames are little-endian; the wire format copies host memory as it is.
static_assert(std::endian::native == std::endian::little, "RAW frames assume a little-endian host");

absl::Status invalid_format(std::string_view field, std::string_view member, std::string_view why) {
  return absl::InvalidArgumentError(
      absl::StrCat(std::string(field), ".", std::string(member), ": ", std::string(why)));
}

// An OpenEXR output stream that grows a string: EXR files are built in memory and sent, never
// written to disk.
class StringOStream : public Imf::OStream {
 public:
  StringOStream() : Imf::OStream("frame.exr") {}
  void write(const char c[], int n) override {
    const size_t end = position_ + static_cast<size_t>(n);
    if (bytes_.size() < end) bytes_.resize(end);
    std::memcpy(bytes_.data() + position_, c, static_cast<size_t>(n));
    position_ = end;
  }
  uint64_t tellp() override { return position_; }
  void seekp(uint64_t pos) override { position_ = pos; }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
  size_t position_ = 0;
};

}  // namespace

absl::StatusOr<FrameSpec> parse_frame_format(const v1::FrameFormat& format,
                                             std::string_view field) {
  FrameSpec spec;
  switch (format.pixel_format()) {
    case v1::PIXEL_FORMAT_UNSPECIFIED:
    case v1::RGBA8_SRGB:
      spec.pixel_format = v1::RGBA8_SRGB;
      break;
    case v1::RGBA16F_LINEAR:
    case v1::RGBA32F_LINEAR:
      spec.pixel_format = format.pixel_format();
      break;
    default:
      return invalid_format(field, "pixel_format",
                            absl::StrCat("unknown pixel format ", format.pixel_format()));
  }
  switch (format.encoding()) {
    case v1::ENCODING_UNSPECIFIED:
    case v1::RAW:
      spec.encoding = v1::RAW;
      break;
    case v1::PNG:
    case v1::EXR:
      spec.encoding = format.encoding();
      break;
    default:
      return invalid_format(field, "encoding",
                            absl::StrCat("unknown encoding ", format.encoding()));
  }
  if (spec.encoding == v1::PNG && spec.pixel_format != v1::RGBA8_SRGB) {
    return invalid_format(
        field, "encoding",
        absl::StrCat("PNG holds RGBA8_SRGB only, not ", v1::PixelFormat_Name(spec.pixel_format)));
  }
  if (spec.encoding == v1::EXR && spec.pixel_format == v1::RGBA8_SRGB) {
    return invalid_format(field, "encoding",
                          "EXR holds RGBA16F_LINEAR or RGBA32F_LINEAR only, not RGBA8_SRGB");
  }
  if (!std::isfinite(format.exposure_stops())) {
    return invalid_format(field, "exposure_stops", "is not finite");
  }
  spec.exposure_stops = format.exposure_stops();
  return spec;
}

uint16_t float_to_half(float value) {
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  const uint16_t sign = static_cast<uint16_t>((bits >> 16) & 0x8000u);
  const uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude >= 0x7f800000u) {  // infinity, or NaN kept quiet with its top payload bits
    const uint32_t nan = magnitude > 0x7f800000u ? 0x200u | ((magnitude >> 13) & 0x3ffu) : 0u;
    return static_cast<uint16_t>(sign | 0x7c00u | nan);
  }
  if (magnitude >= 0x477ff000u) return sign | 0x7c00u;  // >= 65520 rounds past the largest half
  if (magnitude < 0x38800000u) {
    // Below 2^-14: a half subnormal counts units of 2^-24. The float is mantissa * 2^(e - 150)
    // with the implicit bit, so it holds mantissa >> (126 - e) units plus a remainder.
    if (magnitude < 0x33000000u) return sign;  // under half the smallest subnormal
    const uint32_t exponent = magnitude >> 23;
    const uint32_t mantissa = (magnitude & 0x7fffffu) | 0x800000u;
    const uint32_t shift = 126 - exponent;  // 14..24
    uint32_t units = mantissa >> shift;
    const uint32_t remainder = mantissa & ((1u << shift) - 1);
    const uint32_t halfway = 1u << (shift - 1);
    if (remainder > halfway || (remainder == halfway && (units & 1u))) ++units;
    return static_cast<uint16_t>(sign | units);  // 0x400 when rounding up to the smallest normal
  }
  // Normal: rebias the exponent (127 -> 15) and drop 13 mantissa bits; a carry out of the
  // mantissa correctly bumps the exponent.
  uint32_t half = (magnitude - 0x38000000u) >> 13;
  const uint32_t remainder = magnitude & 0x1fffu;
  if (remainder > 0x1000u || (remainder == 0x1000u && (half & 1u))) ++half;
  return static_cast<uint16_t>(sign | half);
}

size_t bytes_per_pixel(v1::PixelFormat format) {
  switch (format) {
    case v1::RGBA16F_LINEAR:
      return 8;
    case v1::RGBA32F_LINEAR:
      return 16;
    default:
      return 4;
  }
}

absl::StatusOr<std::string> encode_png(int width, int height, std::span<const Rgba8> pixels) {
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;
  // The first call only measures.
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, pixels.data(), 0, nullptr)) {
    return absl::InternalError(absl::StrCat("PNG encoding failed: ", image.message));
  }
  std::string png(size, '\0');
  if (!png_image_write_to_memory(&image, png.data(), &size, 0, pixels.data(), 0, nullptr)) {
    return absl::InternalError(absl::StrCat("PNG encoding failed: ", image.message));
  }
  png.resize(size);
  return png;
}

absl::StatusOr<std::string> encode_exr(int width, int height, std::span<const float> rgba,
                                       bool half) {
  const size_t pixel_count = static_cast<size_t>(width) * height;
  std::vector<uint16_t> halves;
  const char* base = reinterpret_cast<const char*>(rgba.data());
  size_t channel_stride = sizeof(float);
  Imf::PixelType type = Imf::FLOAT;
  if (half) {
    // Converted here so EXR and RAW halves round identically.
    halves.resize(pixel_count * 4);
    for (size_t i = 0; i < halves.size(); ++i) halves[i] = float_to_half(rgba[i]);
    base = reinterpret_cast<const char*>(halves.data());
    channel_stride = sizeof(uint16_t);
    type = Imf::HALF;
  }
  // OpenEXR reports errors by exceptions; none may leave this module.
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame_buffer;
    const char* names[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; ++c) {
      header.channels().insert(names[c], Imf::Channel(type));
      frame_buffer.insert(names[c], Imf::Slice(type, const_cast<char*>(base + c * channel_stride),
                                               4 * channel_stride,
                                               4 * channel_stride * static_cast<size_t>(width)));
    }
    StringOStream stream;
    {
      Imf::OutputFile file(stream, header);
      file.setFrameBuffer(frame_buffer);
      file.writePixels(height);
    }  // the destructor writes the line offset table
    return stream.take();
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("EXR encoding failed: ", e.what()));
  }
}

absl::StatusOr<std::string> encode_frame(const FrameSpec& spec, int width, int height,
                                         std::span<const Rgba8> srgb8,
                                         std::span<const float> linear) {
  const bool half = spec.pixel_format == v1::RGBA16F_LINEAR;
  switch (spec.encoding) {
    case v1::PNG:
      return encode_png(width, height, srgb8);
    case v1::EXR:
      return encode_exr(width, height, linear, half);
    default:
      break;
  }
  if (spec.wants_srgb8()) {
    return std::string(reinterpret_cast<const char*>(srgb8.data()), srgb8.size() * sizeof(Rgba8));
  }
  if (!half) {
    return std::string(reinterpret_cast<const char*>(linear.data()), linear.size() * sizeof(float));
  }
  std::string raw(linear.size() * sizeof(uint16_t), '\0');
  for (size_t i = 0; i < linear.size(); ++i) {
    const uint16_t h = float_to_half(linear[i]);
    std::memcpy(raw.data() + 2 * i, &h, sizeof(h));
  }
  return raw;
}

std::vector<v1::Frame> split_frame(const v1::Frame& header, std::string data,
                                   size_t max_chunk_bytes) {
  const size_t chunk = std::max<size_t>(max_chunk_bytes, 1);
  const size_t total = data.size();
  std::vector<v1::Frame> pieces;
  size_t offset = 0;
  do {
    const size_t size = std::min(chunk, total - offset);
    v1::Frame& piece = pieces.emplace_back(header);
    piece.set_data_size(total);
    piece.set_data_offset(offset);
    // A frame in one message takes the bytes without a copy.
    piece.set_data(size == total ? std::move(data) : data.substr(offset, size));
    offset += size;
    piece.set_last_chunk(offset == total);
  } while (offset < total);
  return pieces;
}

}  // namespace caustica::server
