// Piece-by-piece frame reassembly (see frame_assembler.h).
#include "client/frame_assembler.h"

#include <utility>

#include "absl/strings/str_cat.h"

namespace caustica::client {
namespace {

// Reserving more than this up front is left to the appends, so that a corrupt data_size cannot
// make one message allocate gigabytes.
constexpr uint64_t kMaxReserve = uint64_t{1} << 28;

absl::Status frame_error(uint64_t frame_number, std::string_view problem) {
  return absl::DataLossError(absl::StrCat("frame ", frame_number, ": ",
                                          absl::string_view(problem.data(), problem.size())));
}

}  // namespace

size_t raw_bytes_per_pixel(v1::PixelFormat format) {
  switch (format) {
    case v1::PIXEL_FORMAT_UNSPECIFIED:
    case v1::RGBA8_SRGB:
      return 4;
    case v1::RGBA16F_LINEAR:
      return 8;
    case v1::RGBA32F_LINEAR:
      return 16;
    default:
      return 0;
  }
}

absl::Status FrameAssembler::check_first_piece(const v1::Frame& piece) const {
  const uint64_t n = piece.frame_number();
  if (last_frame_number_ && n <= *last_frame_number_) {
    return frame_error(n, absl::StrCat("arrived after frame ", *last_frame_number_,
                                       " (frame numbers must increase)"));
  }
  if (piece.data_offset() != 0) {
    return frame_error(n, absl::StrCat("first piece starts at byte ", piece.data_offset(),
                                       ", expected 0 (pieces missing or out of order)"));
  }
  if (piece.width() == 0 || piece.height() == 0) {
    return frame_error(n, absl::StrCat("size ", piece.width(), "x", piece.height(), " is empty"));
  }
  const bool raw = piece.encoding() == v1::ENCODING_UNSPECIFIED || piece.encoding() == v1::RAW;
  if (raw) {
    const size_t pixel_bytes = raw_bytes_per_pixel(piece.pixel_format());
    if (pixel_bytes == 0) {
      return frame_error(n, absl::StrCat("unknown pixel_format ", piece.pixel_format()));
    }
    const uint64_t expected = uint64_t{piece.width()} * piece.height() * pixel_bytes;
    if (piece.data_size() != expected) {
      return frame_error(n, absl::StrCat("data_size ", piece.data_size(), " does not match ",
                                         piece.width(), "x", piece.height(), " raw pixels of ",
                                         pixel_bytes, " bytes (", expected, ")"));
    }
  }
  if (piece.data().size() > piece.data_size()) {
    return frame_error(n, absl::StrCat("piece of ", piece.data().size(),
                                       " bytes exceeds data_size ", piece.data_size()));
  }
  return absl::OkStatus();
}

absl::Status FrameAssembler::check_next_piece(const v1::Frame& piece) const {
  const v1::Frame& frame = *partial_;
  const uint64_t n = frame.frame_number();
  const uint64_t received = frame.data().size();
  if (piece.frame_number() != n) {
    return frame_error(n, absl::StrCat("ended after ", received, " of ", frame.data_size(),
                                       " bytes: frame ", piece.frame_number(), " began"));
  }
  if (piece.width() != frame.width() || piece.height() != frame.height() ||
      piece.pixel_format() != frame.pixel_format() || piece.encoding() != frame.encoding() ||
      piece.data_size() != frame.data_size()) {
    return frame_error(n, absl::StrCat("the piece at byte ", piece.data_offset(),
                                       " changes the size, format or data_size of the frame"));
  }
  if (piece.data_offset() != received) {
    return frame_error(
        n,
        absl::StrCat("piece at byte ", piece.data_offset(), ", expected byte ", received,
                     piece.data_offset() > received ? " (a gap)" : " (out of order or repeated)"));
  }
  if (piece.data().size() > frame.data_size() - received) {
    return frame_error(n, absl::StrCat("piece of ", piece.data().size(), " bytes at byte ",
                                       received, " runs past data_size ", frame.data_size()));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::optional<v1::Frame>> FrameAssembler::add(v1::Frame piece) {
  const bool last_chunk = piece.last_chunk();
  if (!partial_) {
    if (absl::Status s = check_first_piece(piece); !s.ok()) return s;
    last_frame_number_ = piece.frame_number();
    if (!last_chunk && piece.data_size() <= kMaxReserve) {
      piece.mutable_data()->reserve(piece.data_size());
    }
    partial_ = std::move(piece);
  } else {
    if (absl::Status s = check_next_piece(piece); !s.ok()) return s;
    partial_->mutable_data()->append(piece.data());
  }
  return complete_if_whole(last_chunk);
}

absl::StatusOr<std::optional<v1::Frame>> FrameAssembler::complete_if_whole(bool last_chunk) {
  const uint64_t received = partial_->data().size();
  const uint64_t size = partial_->data_size();
  const uint64_t n = partial_->frame_number();
  if (last_chunk && received < size) {
    return frame_error(n, absl::StrCat("last_chunk after ", received, " of ", size, " bytes"));
  }
  if (!last_chunk && received == size) {
    return frame_error(
        n, absl::StrCat("all ", size, " bytes arrived but the piece is not marked last_chunk"));
  }
  if (!last_chunk) return std::nullopt;
  v1::Frame whole = *std::move(partial_);
  partial_.reset();
  whole.set_data_offset(0);
  whole.set_last_chunk(true);
  ++frames_completed_;
  return std::optional<v1::Frame>(std::move(whole));
}

absl::Status FrameAssembler::finish() const {
  if (!partial_) return absl::OkStatus();
  return frame_error(partial_->frame_number(),
                     absl::StrCat("the stream ended after ", partial_->data().size(), " of ",
                                  partial_->data_size(), " bytes"));
}

}  // namespace caustica::client
