#include "server/frame_encoding.h"

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
    case v1::JPEG:
    case v1::EXR:
      spec.encoding = format.encoding();
      break;
    default:
      return invalid_format(field, "encoding",
                            absl::StrCat("unknown encoding ", format.encoding()));
  }
  if ((spec.encoding == v1::PNG || spec.encoding == v1::JPEG) &&
      spec.pixel_format != v1::RGBA8_SRGB) {
    return invalid_format(
        field, "encoding",
        absl::StrCat(v1::Encoding_Name(spec.encoding), " holds RGBA8_SRGB only, not ",
                     v1::PixelFormat_Name(spec.pixel_format)));
  }
  if (format.jpeg_quality() > 100) {
    return invalid_format(field, "jpeg_quality",
                          absl::StrCat(format.jpeg_quality(), " is not in [1, 100] (0 = 90)"));
  }
  if (format.jpeg_strips() > static_cast<uint32_t>(kMaxJpegStrips)) {
    return invalid_format(field, "jpeg_strips",
                          absl::StrCat(format.jpeg_strips(), " is not in [1, ", kMaxJpegStrips,
                                       "] (0 = 1, one JPEG)"));
  }
  if (format.jpeg_strips() > 1) spec.jpeg_strips = static_cast<int>(format.jpeg_strips());
  if (format.jpeg_quality() != 0) spec.jpeg_quality = static_cast<int>(format.jpeg_quality());
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

absl::StatusOr<std::string> encode_frame(const FrameSpec& spec, int width, int height,
                                         std::span<const Rgba8> srgb8,
                                         std::span<const float> linear, v1::Frame* header) {
  const bool half = spec.pixel_format == v1::RGBA16F_LINEAR;
  const std::span<const uint8_t> srgb8_bytes(reinterpret_cast<const uint8_t*>(srgb8.data()),
                                             srgb8.size_bytes());
  switch (spec.encoding) {
    case v1::PNG:
      return encode_png(width, height, srgb8_bytes);
    case v1::JPEG: {
      if (spec.jpeg_strips <= 1) return encode_jpeg(width, height, srgb8_bytes, spec.jpeg_quality);
      absl::StatusOr<JpegStrips> strips =
          encode_jpeg_strips(width, height, srgb8_bytes, spec.jpeg_quality, spec.jpeg_strips);
      if (!strips.ok()) return strips.status();
      if (header != nullptr) {
        header->mutable_strip_bytes()->Assign(strips->strip_bytes.begin(),
                                              strips->strip_bytes.end());
        header->mutable_strip_rows()->Assign(strips->strip_rows.begin(), strips->strip_rows.end());
      }
      return std::move(strips->data);
    }
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

size_t frame_chunk_bytes(uint32_t requested, size_t max_message_bytes) {
  const size_t limit = std::max(max_message_bytes, 2 * kFrameHeaderRoom) - kFrameHeaderRoom;
  const size_t asked = requested == 0 ? kDefaultChunkBytes : size_t{requested};
  return std::min(std::max(asked, kMinChunkBytes), limit);
}

bool for_each_frame_chunk(const v1::Frame& header, std::string& data, size_t chunk_bytes,
                          const std::function<bool(const v1::Frame&)>& write) {
  const size_t chunk = std::max<size_t>(chunk_bytes, 1);
  v1::Frame piece = header;
  piece.set_data_size(data.size());
  if (data.size() <= chunk) {
    // One message: the bytes are lent to it rather than copied, and taken back for the next send.
    piece.set_data_offset(0);
    piece.set_last_chunk(true);
    piece.mutable_data()->swap(data);
    const bool written = write(piece);
    piece.mutable_data()->swap(data);
    return written;
  }
  size_t offset = 0;
  do {
    const size_t size = std::min(chunk, data.size() - offset);
    piece.set_data_offset(offset);
    // Reuses the piece's buffer: one chunk's bytes are held, whatever the frame's size.
    piece.mutable_data()->assign(data.data() + offset, size);
    offset += size;
    piece.set_last_chunk(offset == data.size());
    if (!write(piece)) return false;
  } while (offset < data.size());
  return true;
}

}  // namespace caustica::server
