// Frames to image files (see frame_image.h).
#include "client/frame_image.h"

#include <cstring>
#include <fstream>
#include <optional>
#include <span>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "imageio/image_encoding.h"

namespace caustica::client {
namespace {

enum class FileKind { kPng, kJpeg, kExr, kPfm };

std::optional<FileKind> file_kind(const std::filesystem::path& path) {
  const std::string extension = absl::AsciiStrToLower(path.extension().string());
  if (extension == ".png") return FileKind::kPng;
  if (extension == ".jpg" || extension == ".jpeg") return FileKind::kJpeg;
  if (extension == ".exr") return FileKind::kExr;
  if (extension == ".pfm") return FileKind::kPfm;
  return std::nullopt;
}

absl::Status unsupported(const std::filesystem::path& path) {
  const std::string extension = path.extension().string();
  return absl::InvalidArgumentError(absl::StrCat(path.string(), ": cannot write ",
                                                 extension.empty()
                                                     ? std::string("a file without an extension")
                                                     : absl::StrCat("'", extension, "' files"),
                                                 " (the CLI writes .png, .jpg, .exr and .pfm)"));
}

v1::Encoding encoding_of(FileKind kind) {
  switch (kind) {
    case FileKind::kPng:
      return v1::PNG;
    case FileKind::kJpeg:
      return v1::JPEG;
    case FileKind::kExr:
      return v1::EXR;
    case FileKind::kPfm:
      break;
  }
  return v1::RAW;
}

bool is_raw(const v1::Frame& frame) {
  return frame.encoding() == v1::RAW || frame.encoding() == v1::ENCODING_UNSPECIFIED;
}

absl::Status wrong_size(const v1::Frame& frame) {
  return absl::DataLossError(absl::StrCat("frame ", frame.frame_number(), ": ", frame.data().size(),
                                          " bytes do not hold ", frame.width(), "x", frame.height(),
                                          " pixels"));
}

// A RAW frame encoded as `kind`: 8-bit files from 8-bit sRGB frames, float files from float ones
// (the pixel format the server was asked for, frame_format_for).
absl::StatusOr<std::string> encode_raw(const v1::Frame& frame, FileKind kind) {
  const int width = static_cast<int>(frame.width()), height = static_cast<int>(frame.height());
  const size_t values = size_t{frame.width()} * frame.height() * 4;
  const std::string& data = frame.data();
  const bool srgb8 = frame.pixel_format() == v1::RGBA8_SRGB ||
                     frame.pixel_format() == v1::PIXEL_FORMAT_UNSPECIFIED;
  const bool eight_bit_file = kind == FileKind::kPng || kind == FileKind::kJpeg;
  if (srgb8 && eight_bit_file) {
    if (data.size() != values) return wrong_size(frame);
    const std::span<const uint8_t> bytes(reinterpret_cast<const uint8_t*>(data.data()),
                                         data.size());
    return kind == FileKind::kPng ? encode_png(width, height, bytes)
                                  : encode_jpeg(width, height, bytes, 90);
  }
  if (frame.pixel_format() == v1::RGBA32F_LINEAR && !eight_bit_file) {
    if (data.size() != values * sizeof(float)) return wrong_size(frame);
    std::vector<float> rgba(values);
    std::memcpy(rgba.data(), data.data(), data.size());
    return kind == FileKind::kPfm ? encode_pfm(width, height, rgba)
                                  : encode_exr(width, height, rgba, /*half=*/false);
  }
  return absl::UnimplementedError(absl::StrCat("a RAW ", v1::PixelFormat_Name(frame.pixel_format()),
                                               " frame is not written to ",
                                               eight_bit_file ? "an 8-bit" : "a float", " file"));
}

}  // namespace

absl::StatusOr<v1::FrameFormat> frame_format_for(const std::filesystem::path& output,
                                                 float exposure_stops) {
  const std::optional<FileKind> kind = file_kind(output);
  if (!kind) return unsupported(output);
  v1::FrameFormat format;
  format.set_encoding(encoding_of(*kind));
  if (*kind == FileKind::kExr || *kind == FileKind::kPfm) {
    format.set_pixel_format(v1::RGBA32F_LINEAR);  // float files take no exposure
  } else {
    format.set_pixel_format(v1::RGBA8_SRGB);
    format.set_exposure_stops(exposure_stops);
  }
  return format;
}

absl::StatusOr<std::string> frame_file_bytes(const v1::Frame& frame,
                                             const std::filesystem::path& path) {
  const std::optional<FileKind> kind = file_kind(path);
  if (!kind) return unsupported(path);
  if (is_raw(frame)) return encode_raw(frame, *kind);
  if (frame.encoding() != encoding_of(*kind)) {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": the frame is ",
                                                   v1::Encoding_Name(frame.encoding()),
                                                   ", not what this extension holds"));
  }
  return frame.data();
}

absl::Status write_frame(const v1::Frame& frame, const std::filesystem::path& path) {
  absl::StatusOr<std::string> bytes = frame_file_bytes(frame, path);
  if (!bytes.ok()) return bytes.status();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes->data(), static_cast<std::streamsize>(bytes->size()));
  out.close();
  if (!out) {
    return absl::InternalError(
        absl::StrCat(path.string(), ": cannot write (", std::strerror(errno), ")"));
  }
  return absl::OkStatus();
}

}  // namespace caustica::client
