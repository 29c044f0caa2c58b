// Image files in memory, without OpenImageIO: PNG (libpng), JPEG (libjpeg-turbo), OpenEXR and
// PFM. The server encodes frames with these, and the CLI writes what arrives (or encodes a RAW
// frame itself), so neither carries OpenImageIO's ~300 shared libraries to a GPU host.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace caustica {

// IEEE 754 binary16 of `value`, rounded to nearest, ties to even; overflow gives infinity and NaN
// stays NaN.
uint16_t float_to_half(float value);

// 8-bit sRGB RGBA pixels (width * height * 4 bytes, top row first) as they are.
absl::StatusOr<std::string> encode_png(int width, int height, std::span<const uint8_t> rgba8);
// The same pixels as a baseline JPEG of `quality` in [1, 100]; alpha is dropped.
absl::StatusOr<std::string> encode_jpeg(int width, int height, std::span<const uint8_t> rgba8,
                                        int quality);

// The most strips encode_jpeg_strips splits an image into.
inline constexpr int kMaxJpegStrips = 16;

// One image as horizontal strips, each a complete JPEG, concatenated in `data` top strip first.
struct JpegStrips {
  std::string data;
  std::vector<uint32_t> strip_bytes;  // each strip's length in `data`, in order
  std::vector<uint32_t> strip_rows;   // each strip's image rows, in order
};

// The same pixels as encode_jpeg, as up to `strips` JPEGs of consecutive rows encoded in parallel,
// one thread each, so that a decoder can also work on them in parallel. Every strip but the last
// holds a multiple of 16 rows, so no chroma block straddles a seam; an image of fewer 16-row
// blocks than `strips` gets one strip per block. One strip gives exactly encode_jpeg's bytes.
// INVALID_ARGUMENT for `strips` outside [1, kMaxJpegStrips].
absl::StatusOr<JpegStrips> encode_jpeg_strips(int width, int height, std::span<const uint8_t> rgba8,
                                              int quality, int strips);
// Linear RGBA floats (width * height * 4, top row first), ZIP-compressed, as half or float.
absl::StatusOr<std::string> encode_exr(int width, int height, std::span<const float> rgba,
                                       bool half);
// Linear RGBA floats as a little-endian colour PFM (alpha dropped, rows bottom to top).
absl::StatusOr<std::string> encode_pfm(int width, int height, std::span<const float> rgba);

}  // namespace caustica
