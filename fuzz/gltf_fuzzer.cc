// glTF 2.0 through load_mesh_file, as a scene's "mesh" shape loads it: inputs that start with the
// binary container's magic "glTF" are written to the scratch directory as fuzz.glb, all others as
// fuzz.gltf (JSON, whose buffers the seeds embed as data: URIs), so one corpus covers both.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz/fuzz_scratch.h"
#include "fuzz/mesh_contract.h"
#include "renderer/scene/mesh_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const caustica::fuzz::ScratchDirectory scratch("gltf");
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const bool binary = input.substr(0, 4) == "glTF";
  const std::filesystem::path path = scratch.path() / (binary ? "fuzz.glb" : "fuzz.gltf");
  caustica::fuzz::write_file(path, input);
  const absl::StatusOr<caustica::MeshFile> file = caustica::load_mesh_file(path);
  if (file.ok()) caustica::fuzz::check_mesh_file(*file);
  return 0;
}
