#include "imageio/image_encoding.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>
#include <jpeglib.h>
#include <png.h>

#include <algorithm>
#include <bit>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace caustica {
namespace {

static_assert(std::endian::native == std::endian::little, "PFM and RAW frames are little-endian");

absl::Status check_size(int width, int height, size_t values, size_t per_pixel) {
  if (width <= 0 || height <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot encode a ", width, "x", height, " image"));
  }
  if (values != static_cast<size_t>(width) * static_cast<size_t>(height) * per_pixel) {
    return absl::InvalidArgumentError(
        absl::StrCat(values, " values do not hold ", width, "x", height, " pixels of ", per_pixel));
  }
  return absl::OkStatus();
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

// libpng and libjpeg report errors by longjmp. Everything between setjmp and the jump is plain C
// state, so no C++ destructor is skipped; the message is copied out before returning.
struct PngWriter {
  std::string* out;
  jmp_buf jump;
  char message[200];
};

void png_append(png_structp png, png_bytep data, png_size_t size) {
  auto* writer = static_cast<PngWriter*>(png_get_io_ptr(png));
  writer->out->append(reinterpret_cast<const char*>(data), size);
}

void png_fail(png_structp png, png_const_charp message) {
  auto* writer = static_cast<PngWriter*>(png_get_error_ptr(png));
  std::snprintf(writer->message, sizeof(writer->message), "%s", message);
  longjmp(writer->jump, 1);
}

void png_ignore_warning(png_structp, png_const_charp) {}

struct JpegError {
  jpeg_error_mgr manager;
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void jpeg_fail(j_common_ptr info) {
  auto* error = reinterpret_cast<JpegError*>(info->err);
  (*info->err->format_message)(info, error->message);
  longjmp(error->jump, 1);
}

// Kept apart from encode_jpeg so that the setjmp frame holds no C++ objects.
bool jpeg_compress_rgba(int width, int height, const uint8_t* rgba8, int quality,
                        unsigned char** buffer, unsigned long* size, JpegError* error) {
  jpeg_compress_struct info;
  info.err = jpeg_std_error(&error->manager);
  error->manager.error_exit = jpeg_fail;
  if (setjmp(error->jump)) {
    jpeg_destroy_compress(&info);
    return false;
  }
  jpeg_create_compress(&info);
  jpeg_mem_dest(&info, buffer, size);
  info.image_width = static_cast<JDIMENSION>(width);
  info.image_height = static_cast<JDIMENSION>(height);
  info.input_components = 4;
  info.in_color_space = JCS_EXT_RGBA;  // libjpeg-turbo reads RGBA and drops the alpha itself
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  jpeg_start_compress(&info, TRUE);
  const size_t stride = static_cast<size_t>(width) * 4;
  while (info.next_scanline < info.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(rgba8 + info.next_scanline * stride);
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  return true;
}

bool png_compress_rgba(int width, int height, const uint8_t* rgba8, PngWriter* writer) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, writer, png_fail, png_ignore_warning);
  if (png == nullptr) {
    std::snprintf(writer->message, sizeof(writer->message), "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(writer->jump)) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, writer, png_append, nullptr);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  // Frames are encoded on the way to the client, where speed matters more than the last few
  // percent of size: zlib level 3 and one cheap filter rather than libpng's adaptive search.
  png_set_compression_level(png, 3);
  png_set_filter(png, 0, PNG_FILTER_UP);
  png_write_info(png, info);
  const size_t stride = static_cast<size_t>(width) * 4;
  for (int y = 0; y < height; ++y) {
    png_write_row(png, const_cast<png_bytep>(rgba8 + static_cast<size_t>(y) * stride));
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

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

absl::StatusOr<std::string> encode_png(int width, int height, std::span<const uint8_t> rgba8) {
  if (absl::Status size = check_size(width, height, rgba8.size(), 4); !size.ok()) return size;
  std::string png;
  png.reserve(rgba8.size() / 2);
  PngWriter writer{.out = &png, .jump = {}, .message = {}};
  if (!png_compress_rgba(width, height, rgba8.data(), &writer)) {
    return absl::InternalError(absl::StrCat("PNG encoding failed: ", writer.message));
  }
  return png;
}

absl::StatusOr<std::string> encode_jpeg(int width, int height, std::span<const uint8_t> rgba8,
                                        int quality) {
  absl::StatusOr<JpegStrips> whole = encode_jpeg_strips(width, height, rgba8, quality, 1);
  if (!whole.ok()) return whole.status();
  return std::move(whole->data);
}

absl::StatusOr<JpegStrips> encode_jpeg_strips(int width, int height, std::span<const uint8_t> rgba8,
                                              int quality, int strips) {
  if (strips < 1 || strips > kMaxJpegStrips) {
    return absl::InvalidArgumentError(
        absl::StrCat(strips, " JPEG strips is not in [1, ", kMaxJpegStrips, "]"));
  }
  if (absl::Status size = check_size(width, height, rgba8.size(), 4); !size.ok()) return size;
  if (quality < 1 || quality > 100) {
    return absl::InvalidArgumentError(
        absl::StrCat("JPEG quality ", quality, " is not in [1, 100]"));
  }
  // Whole 16-row blocks (4:2:0 chroma covers 16 rows) dealt out as evenly as they go, the extra
  // ones to the top strips; the last strip ends at the image's last row.
  const int blocks = (height + 15) / 16;
  const int count = std::min(strips, blocks);
  std::vector<int> first_row(static_cast<size_t>(count) + 1, 0);
  for (int i = 0; i < count; ++i) {
    const int strip_blocks = blocks / count + (i < blocks % count ? 1 : 0);
    first_row[i + 1] = std::min(height, first_row[i] + 16 * strip_blocks);
  }
  struct Strip {
    unsigned char* buffer = nullptr;
    unsigned long size = 0;
    JpegError error{};
    bool ok = false;
  };
  std::vector<Strip> results(static_cast<size_t>(count));
  const size_t stride = static_cast<size_t>(width) * 4;
  auto encode_strip = [&](int i) {
    Strip& strip = results[i];
    strip.ok = jpeg_compress_rgba(width, first_row[i + 1] - first_row[i],
                                  rgba8.data() + static_cast<size_t>(first_row[i]) * stride,
                                  quality, &strip.buffer, &strip.size, &strip.error);
  };
  {
    // The first strip is encoded on this thread while the others run on their own.
    std::vector<std::jthread> threads;
    threads.reserve(static_cast<size_t>(count) - 1);
    for (int i = 1; i < count; ++i) threads.emplace_back(encode_strip, i);
    encode_strip(0);
  }
  JpegStrips out;
  size_t total = 0;
  for (const Strip& strip : results) total += strip.size;
  out.data.reserve(total);
  std::optional<std::string> failure;
  for (int i = 0; i < count; ++i) {
    Strip& strip = results[i];
    if (!strip.ok && !failure) failure = strip.error.message;
    if (!failure) {
      out.data.append(reinterpret_cast<const char*>(strip.buffer), strip.size);
      out.strip_bytes.push_back(static_cast<uint32_t>(strip.size));
      out.strip_rows.push_back(static_cast<uint32_t>(first_row[i + 1] - first_row[i]));
    }
    std::free(strip.buffer);
  }
  if (failure) return absl::InternalError(absl::StrCat("JPEG encoding failed: ", *failure));
  return out;
}

absl::StatusOr<std::string> encode_exr(int width, int height, std::span<const float> rgba,
                                       bool half) {
  if (absl::Status size = check_size(width, height, rgba.size(), 4); !size.ok()) return size;
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

absl::StatusOr<std::string> encode_pfm(int width, int height, std::span<const float> rgba) {
  if (absl::Status size = check_size(width, height, rgba.size(), 4); !size.ok()) return size;
  // "PF" is colour; a negative scale says little-endian.
  std::string pfm = absl::StrCat("PF\n", width, " ", height, "\n-1.0\n");
  const size_t header = pfm.size();
  pfm.resize(header + static_cast<size_t>(width) * height * 3 * sizeof(float));
  char* out = pfm.data() + header;
  for (int y = height - 1; y >= 0; --y) {
    for (int x = 0; x < width; ++x) {
      std::memcpy(out, &rgba[4 * (static_cast<size_t>(y) * width + x)], 3 * sizeof(float));
      out += 3 * sizeof(float);
    }
  }
  return pfm;
}

}  // namespace caustica
