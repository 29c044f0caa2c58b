// PLY through load_mesh_file, as a scene's "mesh" shape loads it: ascii and both binary bodies,
// and gzip-compressed files, which take the path through read_file's inflation. Each input is
// written to the scratch directory as fuzz.ply, or fuzz.ply.gz when it starts with gzip's magic.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz/fuzz_scratch.h"
#include "fuzz/mesh_contract.h"
#include "renderer/scene/mesh_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const caustica::fuzz::ScratchDirectory scratch("ply");
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const bool gzip = input.size() >= 2 && input[0] == '\x1f' && input[1] == '\x8b';
  const std::filesystem::path path = scratch.path() / (gzip ? "fuzz.ply.gz" : "fuzz.ply");
  caustica::fuzz::write_file(path, input);
  const absl::StatusOr<caustica::MeshFile> file = caustica::load_mesh_file(path);
  if (file.ok()) caustica::fuzz::check_mesh_file(*file);
  return 0;
}
