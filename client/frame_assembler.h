// Reassembly of frames from the pieces a frame stream delivers. A frame larger than the chunk
// size arrives as consecutive Frame messages (see `message Frame` in render_service.proto); this
// checks each piece against the ones before it so that a frame is handed on only whole and exact.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::client {

// Bytes of one pixel in `format` before any encoding; 0 for unknown formats.
size_t raw_bytes_per_pixel(v1::PixelFormat format);

class FrameAssembler {
 public:
  // Takes the next message of the stream. Returns the whole frame (data_offset 0, last_chunk set,
  // all data_size bytes in `data`) once `piece` completes one, nullopt while it is still partial,
  // or DATA_LOSS naming the frame and the problem: a piece out of order or after a gap, header
  // fields that change between pieces, sizes that disagree, a frame begun before the previous one
  // ended, frame numbers that go backwards.
  absl::StatusOr<std::optional<v1::Frame>> add(v1::Frame piece);

  // DATA_LOSS when the stream ended in the middle of a frame.
  absl::Status finish() const;

  uint64_t frames_completed() const { return frames_completed_; }

 private:
  absl::Status check_first_piece(const v1::Frame& piece) const;
  absl::Status check_next_piece(const v1::Frame& piece) const;
  absl::StatusOr<std::optional<v1::Frame>> complete_if_whole(bool last_chunk);

  std::optional<v1::Frame> partial_;  // the frame being assembled
  std::optional<uint64_t> last_frame_number_;
  uint64_t frames_completed_ = 0;
};

}  // namespace caustica::client
