// Frame formats: validation, RAW halves, encoded frames, and frame splitting. The encoders
// themselves are tested in tests/imageio/image_encoding_test.cc.
#include "server/frame_encoding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace caustica::server {
namespace {

TEST(FrameFormat, DefaultsAndRefusedCombinations) {
  v1::FrameFormat format;
  absl::StatusOr<FrameSpec> spec = parse_frame_format(format, "format");
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->pixel_format, v1::RGBA8_SRGB);
  EXPECT_EQ(spec->encoding, v1::RAW);

  format.set_pixel_format(v1::RGBA32F_LINEAR);
  format.set_encoding(v1::PNG);
  spec = parse_frame_format(format, "format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("format.encoding"), std::string::npos)
      << spec.status().message();

  format.set_pixel_format(v1::RGBA8_SRGB);
  format.set_encoding(v1::EXR);
  spec = parse_frame_format(format, "format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("format.encoding"), std::string::npos);

  format.set_pixel_format(static_cast<v1::PixelFormat>(42));
  format.set_encoding(v1::RAW);
  spec = parse_frame_format(format, "format");
  EXPECT_NE(spec.status().message().find("format.pixel_format"), std::string::npos);

  format.set_pixel_format(v1::RGBA16F_LINEAR);
  format.set_encoding(v1::EXR);
  EXPECT_TRUE(parse_frame_format(format, "format").ok());
}

TEST(FrameFormat, JpegHoldsSrgbBytesAtAQualityInRange) {
  v1::FrameFormat format;
  format.set_encoding(v1::JPEG);
  absl::StatusOr<FrameSpec> spec = parse_frame_format(format, "format");
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->jpeg_quality, 90);
  EXPECT_FALSE(spec->raw());

  format.set_jpeg_quality(100);
  spec = parse_frame_format(format, "format");
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->jpeg_quality, 100);

  format.set_jpeg_quality(101);
  spec = parse_frame_format(format, "request.format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("request.format.jpeg_quality"), std::string::npos)
      << spec.status().message();

  format.set_jpeg_quality(0);
  format.set_pixel_format(v1::RGBA16F_LINEAR);
  spec = parse_frame_format(format, "format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("JPEG holds RGBA8_SRGB only"), std::string::npos)
      << spec.status().message();
}

TEST(FrameFormat, JpegStripsAreOneToSixteen) {
  v1::FrameFormat format;
  format.set_encoding(v1::JPEG);
  absl::StatusOr<FrameSpec> spec = parse_frame_format(format, "format");
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->jpeg_strips, 1);
  format.set_jpeg_strips(16);
  spec = parse_frame_format(format, "format");
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->jpeg_strips, 16);
  format.set_jpeg_strips(17);
  spec = parse_frame_format(format, "request.format");
  EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(spec.status().message().find("request.format.jpeg_strips"), std::string::npos)
      << spec.status().message();
}

TEST(FrameEncoding, JpegStripsFillTheHeader) {
  const std::vector<Rgba8> srgb8(8 * 40, Rgba8{10, 200, 30, 255});
  FrameSpec spec;
  spec.encoding = v1::JPEG;
  spec.jpeg_strips = 3;
  v1::Frame header;
  absl::StatusOr<std::string> bytes = encode_frame(spec, 8, 40, srgb8, {}, &header);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  ASSERT_EQ(header.strip_bytes_size(), 3);
  ASSERT_EQ(header.strip_rows_size(), 3);
  EXPECT_EQ(header.strip_rows(0) + header.strip_rows(1) + header.strip_rows(2), 40u);
  EXPECT_EQ(header.strip_bytes(0) + header.strip_bytes(1) + header.strip_bytes(2), bytes->size());
  // Every piece of a split frame carries the strips, as the other header fields.
  for_each_frame_chunk(header, *bytes, 100, [](const v1::Frame& piece) {
    EXPECT_EQ(piece.strip_bytes_size(), 3);
    EXPECT_EQ(piece.strip_rows_size(), 3);
    return true;
  });
  spec.jpeg_strips = 1;
  v1::Frame single;
  bytes = encode_frame(spec, 8, 40, srgb8, {}, &single);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(single.strip_bytes_size(), 0);
}

TEST(FrameEncoding, EncodedFramesAreTheirFiles) {
  const std::vector<Rgba8> srgb8(6, Rgba8{10, 200, 30, 255});
  FrameSpec jpeg;
  jpeg.encoding = v1::JPEG;
  absl::StatusOr<std::string> bytes = encode_frame(jpeg, 3, 2, srgb8, {});
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(bytes->substr(0, 3), "\xff\xd8\xff");  // JPEG start of image
  FrameSpec png;
  png.encoding = v1::PNG;
  bytes = encode_frame(png, 3, 2, srgb8, {});
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(bytes->substr(1, 3), "PNG");
}

TEST(FrameEncoding, RawHalfIsLittleEndianHalves) {
  const std::vector<float> linear = {1.0f, 0.5f, -2.0f, 65504.0f};
  absl::StatusOr<std::string> raw =
      encode_frame({v1::RGBA16F_LINEAR, v1::RAW, 0}, 1, 1, {}, linear);
  ASSERT_TRUE(raw.ok());
  const std::string expected("\x00\x3c\x00\x38\x00\xc0\xff\x7b", 8);
  EXPECT_EQ(*raw, expected);
}

// Every piece of `data` that for_each_frame_chunk writes.
std::vector<v1::Frame> frame_chunks(const v1::Frame& header, std::string_view data,
                                    size_t chunk_bytes) {
  std::vector<v1::Frame> pieces;
  std::string bytes(data);
  EXPECT_TRUE(for_each_frame_chunk(header, bytes, chunk_bytes, [&](const v1::Frame& piece) {
    pieces.push_back(piece);
    return true;
  }));
  return pieces;
}

TEST(FrameSplitting, PiecesCoverTheFrameInOrder) {
  v1::Frame header;
  header.set_frame_number(3);
  header.set_width(9);
  std::string data(10, '\0');
  for (int i = 0; i < 10; ++i) data[i] = char('a' + i);

  const std::vector<v1::Frame> pieces = frame_chunks(header, data, 4);
  ASSERT_EQ(pieces.size(), 3u);
  const uint64_t offsets[] = {0, 4, 8};
  const char* contents[] = {"abcd", "efgh", "ij"};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(pieces[i].frame_number(), 3u);
    EXPECT_EQ(pieces[i].width(), 9u);
    EXPECT_EQ(pieces[i].data_size(), 10u);
    EXPECT_EQ(pieces[i].data_offset(), offsets[i]);
    EXPECT_EQ(pieces[i].data(), contents[i]);
    EXPECT_EQ(pieces[i].last_chunk(), i == 2);
  }

  const std::vector<v1::Frame> whole = frame_chunks(header, data, 10);
  ASSERT_EQ(whole.size(), 1u);
  EXPECT_EQ(whole[0].data(), data);
  EXPECT_TRUE(whole[0].last_chunk());

  const std::vector<v1::Frame> empty = frame_chunks(header, "", 4);
  ASSERT_EQ(empty.size(), 1u);
  EXPECT_EQ(empty[0].data_size(), 0u);
  EXPECT_TRUE(empty[0].last_chunk());
}

TEST(FrameSplitting, ChunkSizesAreClampedBetweenTheMinimumAndTheMessageLimit) {
  const size_t message_limit = size_t{64} << 20;
  EXPECT_EQ(frame_chunk_bytes(1, message_limit), kMinChunkBytes);
  EXPECT_EQ(frame_chunk_bytes(kMinChunkBytes - 1, message_limit), kMinChunkBytes);
  EXPECT_EQ(frame_chunk_bytes(100000, message_limit), 100000u);
  EXPECT_EQ(frame_chunk_bytes(0, message_limit), kDefaultChunkBytes);
  EXPECT_EQ(frame_chunk_bytes(64 << 20, size_t{1} << 20), (size_t{1} << 20) - kFrameHeaderRoom);
}

// A one-byte request on a frame of a few minimum pieces: pieces of the minimum, the last one
// shorter, that put back together are the frame bit for bit.
TEST(FrameSplitting, ATinyChunkSizeGivesPiecesOfTheMinimumThatReassemble) {
  v1::Frame header;
  header.set_frame_number(7);
  header.set_width(256);
  std::string data(3 * kMinChunkBytes + 5, '\0');
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>(i * 131 + i / 7);

  const std::vector<v1::Frame> pieces =
      frame_chunks(header, data, frame_chunk_bytes(1, size_t{64} << 20));
  ASSERT_EQ(pieces.size(), 4u);
  std::string reassembled;
  for (size_t i = 0; i < pieces.size(); ++i) {
    EXPECT_EQ(pieces[i].frame_number(), 7u);
    EXPECT_EQ(pieces[i].width(), 256u);
    EXPECT_EQ(pieces[i].data_size(), data.size());
    EXPECT_EQ(pieces[i].data_offset(), reassembled.size());
    EXPECT_EQ(pieces[i].data().size(), i < 3 ? kMinChunkBytes : 5u);
    EXPECT_EQ(pieces[i].last_chunk(), i == 3);
    reassembled += pieces[i].data();
  }
  EXPECT_TRUE(reassembled == data);
}

TEST(FrameSplitting, StopsAtThePieceTheWriterRefuses) {
  std::string data(10, 'x');
  int written = 0;
  EXPECT_FALSE(
      for_each_frame_chunk(v1::Frame(), data, 4, [&](const v1::Frame&) { return ++written < 2; }));
  EXPECT_EQ(written, 2) << "no piece is built after the refused one";
}

}  // namespace
}  // namespace caustica::server
