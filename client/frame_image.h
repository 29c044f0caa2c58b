// Frames to image files, without OpenImageIO. The CLI asks the server for the file itself: PNG or
// JPEG of 8-bit sRGB with the exposure applied, EXR of linear float; PFM comes as RAW float and
// gets its header here. A RAW frame for any of these is encoded here with the same encoders.
#pragma once

#include <filesystem>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::client {

// The FrameFormat to request for a frame that goes to `output`; INVALID_ARGUMENT naming the
// extension when the CLI cannot write it (it writes .png, .jpg/.jpeg, .exr and .pfm).
absl::StatusOr<v1::FrameFormat> frame_format_for(const std::filesystem::path& output,
                                                 float exposure_stops);

// The file's bytes for a whole frame: an encoded frame as it is (when its encoding is the
// file's), a RAW one encoded.
absl::StatusOr<std::string> frame_file_bytes(const v1::Frame& frame,
                                             const std::filesystem::path& path);

// Writes a whole frame to `path` (format by extension).
absl::Status write_frame(const v1::Frame& frame, const std::filesystem::path& path);

}  // namespace caustica::client
