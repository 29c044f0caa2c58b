// An UploadScene stream through the server's sequence (server/render_service.cc): every chunk
// into wire::SceneAssembler::add, the header's declared bytes against a memory budget once the
// header is in, finish(), then validate_scene, which Engine::load runs before it builds anything
// (its density grid checks included). The input is a stream in the format of chunk_stream.h.
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/util/delimited_message_util.h>

#include <cstddef>
#include <cstdint>

#include "caustica/v1/scene.pb.h"
#include "fuzz/chunk_stream.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/validate.h"

namespace {

// The free device memory the simulated server has for the scene's arrays. Small, so that a
// header may declare (and the assembler reserve) only what fits the fuzzer's memory limit, as
// the real budget check keeps the real server within its device.
constexpr size_t kFreeBudgetBytes = size_t{64} << 20;

void fix_checksum(caustica::v1::SceneChunk* chunk) {
  if (chunk->has_mesh()) {
    chunk->mutable_mesh()->set_crc32(caustica::wire::chunk_crc32(chunk->mesh().data()));
  } else if (chunk->has_grid()) {
    chunk->mutable_grid()->set_crc32(caustica::wire::chunk_crc32(chunk->grid().data()));
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // Protobuf logs an error for every string field that is not UTF-8 before refusing the message;
  // the refusal is what is under test, and the log lines would bury libFuzzer's report.
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool fix_checksums = (data[0] & caustica::fuzz::kFixChecksums) != 0;
  google::protobuf::io::CodedInputStream stream(data + 1, static_cast<int>(size - 1));
  caustica::wire::SceneAssembler assembler;
  bool budget_checked = false;
  caustica::v1::SceneChunk chunk;
  while (true) {
    bool clean_eof = false;
    if (!google::protobuf::util::ParseDelimitedFromCodedStream(&chunk, &stream, &clean_eof)) {
      // A message that does not parse breaks the stream, and a broken stream keeps nothing.
      if (!clean_eof) return 0;
      break;
    }
    if (fix_checksums) fix_checksum(&chunk);
    if (!assembler.add(chunk).ok()) return 0;
    if (!budget_checked && assembler.has_header()) {
      budget_checked = true;
      if (assembler.bytes_declared() > kFreeBudgetBytes) return 0;
    }
  }
  const absl::StatusOr<caustica::Scene> scene = assembler.finish();
  if (!scene.ok()) return 0;
  (void)caustica::validate_scene(*scene);
  return 0;
}
