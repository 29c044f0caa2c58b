// The input format of the scene_chunks fuzz target, shared with the seed generator: one byte of
// flags, then SceneChunk messages, each preceded by its length as a varint (protobuf's delimited
// format, util/delimited_message_util.h).
#pragma once

#include <cstdint>

namespace caustica::fuzz {

// Flag bit: the harness sets every chunk's crc32 from its data before the assembler sees it, as
// any client (a hostile one too) does. Without it nearly every mutation of chunk data would be
// refused at the checksum, and the checks behind it (offsets, sizes, indices, values, the
// density grid) would go unfuzzed; inputs without it keep covering the checksum test itself.
inline constexpr uint8_t kFixChecksums = 1;

}  // namespace caustica::fuzz
