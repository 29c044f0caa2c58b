// FrameAssembler: frames split into pieces come back byte-exact; pieces out of order, after gaps,
// of the wrong size or of interleaved frames are refused with DATA_LOSS naming the frame.
#include "client/frame_assembler.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace caustica::client {
namespace {

using ::testing::HasSubstr;

v1::Frame header(uint64_t number, uint32_t width, uint32_t height) {
  v1::Frame frame;
  frame.set_scene_id("s");
  frame.set_frame_number(number);
  frame.set_width(width);
  frame.set_height(height);
  frame.set_pixel_format(v1::RGBA8_SRGB);
  frame.set_encoding(v1::RAW);
  frame.set_passes(3);
  frame.mutable_epochs()->set_lights(7);
  frame.set_data_size(uint64_t{width} * height * 4);
  return frame;
}

std::string pixels(size_t size, int seed) {
  std::string data(size, '\0');
  for (size_t i = 0; i < size; ++i) data[i] = static_cast<char>((i * 131 + seed * 17) % 251);
  return data;
}

// The pieces a server sends for `data` in chunks of `chunk` bytes (as message Frame documents).
std::vector<v1::Frame> split(const v1::Frame& head, const std::string& data, size_t chunk) {
  std::vector<v1::Frame> pieces;
  for (size_t offset = 0; offset < data.size(); offset += chunk) {
    v1::Frame piece = head;
    piece.set_data_offset(offset);
    piece.set_data(data.substr(offset, chunk));
    piece.set_last_chunk(offset + chunk >= data.size());
    pieces.push_back(piece);
  }
  return pieces;
}

TEST(FrameAssembler, OneMessageFrameComesBackWhole) {
  FrameAssembler assembler;
  const std::string data = pixels(4 * 4 * 4, 1);
  std::vector<v1::Frame> pieces = split(header(0, 4, 4), data, 1 << 20);
  ASSERT_EQ(pieces.size(), 1u);
  absl::StatusOr<std::optional<v1::Frame>> frame = assembler.add(pieces[0]);
  ASSERT_TRUE(frame.ok()) << frame.status();
  ASSERT_TRUE(frame->has_value());
  EXPECT_EQ((*frame)->data(), data);
  EXPECT_EQ((*frame)->passes(), 3u);
  EXPECT_EQ((*frame)->epochs().lights(), 7u);
  EXPECT_EQ(assembler.frames_completed(), 1u);
  EXPECT_TRUE(assembler.finish().ok());
}

TEST(FrameAssembler, PiecesOfConsecutiveFramesReassembleByteExact) {
  FrameAssembler assembler;
  std::vector<std::string> whole;
  for (uint64_t n = 0; n < 3; ++n) {
    const std::string data = pixels(16 * 8 * 4, static_cast<int>(n));
    // 512 bytes in pieces of 100: the last piece is short.
    std::vector<v1::Frame> pieces = split(header(n, 16, 8), data, 100);
    ASSERT_EQ(pieces.size(), 6u);
    for (size_t i = 0; i < pieces.size(); ++i) {
      absl::StatusOr<std::optional<v1::Frame>> frame = assembler.add(pieces[i]);
      ASSERT_TRUE(frame.ok()) << frame.status();
      ASSERT_EQ(frame->has_value(), i + 1 == pieces.size()) << "piece " << i;
      if (frame->has_value()) {
        EXPECT_EQ((*frame)->frame_number(), n);
        EXPECT_EQ((*frame)->data_offset(), 0u);
        EXPECT_TRUE((*frame)->last_chunk());
        EXPECT_EQ((*frame)->data(), data);
        whole.push_back((*frame)->data());
      }
    }
  }
  EXPECT_EQ(whole.size(), 3u);
  EXPECT_NE(whole[0], whole[1]);
  EXPECT_EQ(assembler.frames_completed(), 3u);
}

absl::Status feed(FrameAssembler& assembler, const std::vector<v1::Frame>& pieces) {
  for (const v1::Frame& piece : pieces) {
    absl::StatusOr<std::optional<v1::Frame>> frame = assembler.add(piece);
    if (!frame.ok()) return frame.status();
  }
  return absl::OkStatus();
}

TEST(FrameAssembler, RefusesAGap) {
  FrameAssembler assembler;
  std::vector<v1::Frame> pieces = split(header(2, 8, 8), pixels(256, 0), 64);
  pieces.erase(pieces.begin() + 1);
  const absl::Status status = feed(assembler, pieces);
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(status.message(), HasSubstr("frame 2: piece at byte 128, expected byte 64 (a gap)"));
}

TEST(FrameAssembler, RefusesPiecesOutOfOrder) {
  FrameAssembler assembler;
  std::vector<v1::Frame> pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  std::swap(pieces[1], pieces[2]);
  EXPECT_THAT(feed(assembler, pieces).message(), HasSubstr("piece at byte 128, expected byte 64"));

  FrameAssembler repeated;
  pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  pieces.insert(pieces.begin() + 2, pieces[1]);
  EXPECT_THAT(feed(repeated, pieces).message(),
              HasSubstr("piece at byte 64, expected byte 128 (out of order or repeated)"));
}

TEST(FrameAssembler, RefusesAFrameThatStartsMidway) {
  FrameAssembler assembler;
  std::vector<v1::Frame> pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  const absl::Status status = feed(assembler, {pieces[1]});
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(status.message(), HasSubstr("first piece starts at byte 64, expected 0"));
}

TEST(FrameAssembler, RefusesWrongSizes) {
  // data_size that does not match width x height RGBA8.
  v1::Frame wrong = header(0, 8, 8);
  wrong.set_data_size(255);
  FrameAssembler a;
  EXPECT_THAT(feed(a, split(wrong, pixels(255, 0), 64)).message(),
              HasSubstr("data_size 255 does not match 8x8 raw pixels of 4 bytes (256)"));

  // A piece that runs past data_size.
  std::vector<v1::Frame> pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  pieces[3].set_data(pixels(65, 0));
  FrameAssembler b;
  EXPECT_THAT(feed(b, pieces).message(), HasSubstr("piece of 65 bytes at byte 192 runs past"));

  // last_chunk before all bytes arrived, and all bytes without last_chunk.
  pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  pieces[2].set_last_chunk(true);
  FrameAssembler c;
  EXPECT_THAT(feed(c, pieces).message(), HasSubstr("last_chunk after 192 of 256 bytes"));
  pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  pieces[3].set_last_chunk(false);
  FrameAssembler d;
  EXPECT_THAT(feed(d, pieces).message(), HasSubstr("not marked last_chunk"));

  // A header that changes between pieces.
  pieces = split(header(0, 8, 8), pixels(256, 0), 64);
  pieces[1].set_width(16);
  FrameAssembler e;
  EXPECT_THAT(feed(e, pieces).message(), HasSubstr("changes the size, format or data_size"));

  // An empty image.
  FrameAssembler f;
  EXPECT_THAT(feed(f, {header(0, 0, 8)}).message(), HasSubstr("size 0x8 is empty"));
}

TEST(FrameAssembler, RefusesInterleavedAndBackwardFrames) {
  std::vector<v1::Frame> first = split(header(0, 8, 8), pixels(256, 0), 64);
  std::vector<v1::Frame> second = split(header(1, 8, 8), pixels(256, 1), 64);
  FrameAssembler interleaved;
  EXPECT_THAT(feed(interleaved, {first[0], second[0]}).message(),
              HasSubstr("frame 0: ended after 64 of 256 bytes: frame 1 began"));

  FrameAssembler backwards;
  ASSERT_TRUE(feed(backwards, second).ok());
  EXPECT_THAT(feed(backwards, first).message(),
              HasSubstr("frame 0: arrived after frame 1 (frame numbers must increase)"));
}

TEST(FrameAssembler, FinishReportsAFrameLeftPartial) {
  FrameAssembler assembler;
  std::vector<v1::Frame> pieces = split(header(4, 8, 8), pixels(256, 0), 100);
  ASSERT_TRUE(feed(assembler, {pieces[0], pieces[1]}).ok());
  const absl::Status status = assembler.finish();
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(status.message(), HasSubstr("frame 4: the stream ended after 200 of 256 bytes"));
}

TEST(FrameAssembler, FloatFramesAreSizedBy16BytesPerPixel) {
  v1::Frame head = header(0, 3, 2);
  head.set_pixel_format(v1::RGBA32F_LINEAR);
  head.set_data_size(3 * 2 * 16);
  FrameAssembler assembler;
  const std::string data = pixels(96, 5);
  absl::StatusOr<std::optional<v1::Frame>> frame;
  for (const v1::Frame& piece : split(head, data, 40)) frame = assembler.add(piece);
  ASSERT_TRUE(frame.ok()) << frame.status();
  ASSERT_TRUE(frame->has_value());
  EXPECT_EQ((*frame)->data(), data);
}

}  // namespace
}  // namespace caustica::client
