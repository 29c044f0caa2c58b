// Frames to image files. The CLI asks the server for the pixel format the file needs: 8-bit sRGB
// with the exposure applied for PNG/JPEG (a quarter of the bytes of float), linear float for
// EXR/PFM, both RAW; imageio writes the file.
#pragma once

#include <filesystem>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"
#include "imageio/image_io.h"

namespace caustica::client {

// The FrameFormat to request for a frame that goes to `output`.
v1::FrameFormat frame_format_for(const std::filesystem::path& output, float exposure_stops);

// A RAW RGBA8_SRGB or RGBA32F_LINEAR frame as linear float RGBA.
absl::StatusOr<LinearImage> frame_to_image(const v1::Frame& frame);

// Writes a whole frame to `path` (format by extension).
absl::Status write_frame(const v1::Frame& frame, const std::filesystem::path& path);

}  // namespace caustica::client
