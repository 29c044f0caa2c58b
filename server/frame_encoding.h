// Frames on the wire: the pixel formats and encodings of caustica.v1.FrameFormat (8-bit sRGB,
// IEEE half and float linear RGBA; raw, or PNG, JPEG and EXR files built in memory by imageio's
// encoders)
// and the splitting of one encoded frame into consecutive Frame messages (see `message Frame`).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"
#include "imageio/image_encoding.h"
#include "renderer/render/film.h"

namespace caustica::server {

// A FrameFormat with the defaults filled in and the combination checked.
struct FrameSpec {
  v1::PixelFormat pixel_format = v1::RGBA8_SRGB;
  v1::Encoding encoding = v1::RAW;
  float exposure_stops = 0;
  int jpeg_quality = 90;
  int jpeg_strips = 1;  // JPEG only: the frame as this many strips (see encode_jpeg_strips)

  // Whether the film is resolved to 8-bit sRGB (else to linear float).
  bool wants_srgb8() const { return pixel_format == v1::RGBA8_SRGB; }
  // Whether the frame is the pixels themselves, not an image file (PNG, JPEG, EXR).
  bool raw() const { return encoding == v1::RAW; }
};

// INVALID_ARGUMENT naming `<field>.pixel_format`, `<field>.encoding` or `<field>.exposure_stops`
// for unknown values and for combinations that do not exist (PNG or JPEG of linear data, EXR of
// 8-bit), `<field>.jpeg_quality` above 100 and `<field>.jpeg_strips` above kMaxJpegStrips.
absl::StatusOr<FrameSpec> parse_frame_format(const v1::FrameFormat& format, std::string_view field);

// Bytes of one pixel in `format` (before any encoding).
size_t bytes_per_pixel(v1::PixelFormat format);

// Encodes a resolved film. `srgb8` is used when spec.wants_srgb8(), else `linear` (RGBA float,
// top row first); both hold width * height pixels. A JPEG of more than one strip is the strips'
// bytes concatenated; `header`, when given, gets their strip_bytes and strip_rows.
absl::StatusOr<std::string> encode_frame(const FrameSpec& spec, int width, int height,
                                         std::span<const Rgba8> srgb8,
                                         std::span<const float> linear,
                                         v1::Frame* header = nullptr);

// Frame bytes per message of a stream whose request leaves max_chunk_bytes at 0.
inline constexpr size_t kDefaultChunkBytes = size_t{4} << 20;
// The fewest frame bytes a piece of a split frame carries, whatever max_chunk_bytes asks: smaller
// pieces would cost more in the header fields each one repeats and in gRPC's work per message than
// they carry, and one request could turn a frame into a message per byte.
inline constexpr size_t kMinChunkBytes = size_t{16} << 10;
// Room for a Frame's header fields next to its data within one message.
inline constexpr size_t kFrameHeaderRoom = size_t{64} << 10;

// The frame bytes per message for a request's max_chunk_bytes: `requested` (0: kDefaultChunkBytes)
// raised to kMinChunkBytes, then lowered to what leaves kFrameHeaderRoom in `max_message_bytes`.
size_t frame_chunk_bytes(uint32_t requested, size_t max_message_bytes);

// Calls `write` with each message that carries `data` under the header fields of `header`, in
// order: pieces of at most `chunk_bytes` (>= 1) of data, each with data_size, data_offset and
// last_chunk set; an empty frame is one message. A piece is built only once `write` returned for
// the one before, so a stream holds its frame and one piece, never all of a frame's pieces. Stops
// at the first piece `write` refuses (returns false); whether it took them all. `data` is lent to
// a frame of one piece and is as it was on return.
bool for_each_frame_chunk(const v1::Frame& header, std::string& data, size_t chunk_bytes,
                          const std::function<bool(const v1::Frame&)>& write);

}  // namespace caustica::server
