// Image files for the tools: linear float formats (EXR, PFM) get the radiance as it is; 8-bit
// formats (PNG, JPEG, ...) get exposure and the sRGB curve. Everything goes through OpenImageIO,
// which stays out of the renderer, the server and the benchmark (it pulls ~300 shared libraries).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "absl/status/statusor.h"

namespace caustica {

struct LinearImage {
  int width = 0, height = 0;
  std::vector<float> rgba;  // 4 floats per pixel, top row first
};

// True for extensions that store linear floats (.exr, .pfm).
bool is_float_format(const std::filesystem::path& path);

// Writes `image` to `path`, choosing the format by extension. 8-bit formats are exposed by
// 2^exposure_stops and sRGB-encoded; float formats ignore the exposure.
absl::Status write_image(const std::filesystem::path& path, const LinearImage& image,
                         float exposure_stops = 0.0f);

// Writes 8-bit sRGB RGBA pixels (width * height * 4 bytes, top row first) to `path` as they are,
// in an 8-bit format chosen by extension (PNG, JPEG, ...): no conversion, so a frame that arrived
// as sRGB bytes is written without going through float.
absl::Status write_srgb8_image(const std::filesystem::path& path, int width, int height,
                               std::span<const uint8_t> rgba);

// Reads any format OpenImageIO knows into linear RGBA float (8-bit files are decoded from sRGB).
absl::StatusOr<LinearImage> read_image(const std::filesystem::path& path);

}  // namespace caustica
