// Wavefront OBJ and its MTL materials through load_mesh_file, as a scene's "mesh" shape loads
// them. tinyobjloader reads only from files, so each input is written to the scratch directory:
// the bytes before a line "#--- fuzz.mtl" become fuzz.obj, those after it fuzz.mtl, which the
// OBJ part can name with "mtllib fuzz.mtl" (the seeds do).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz/fuzz_scratch.h"
#include "fuzz/mesh_contract.h"
#include "renderer/scene/mesh_file.h"

namespace {

constexpr std::string_view kMtlMarker = "\n#--- fuzz.mtl\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const caustica::fuzz::ScratchDirectory scratch("obj");
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const size_t marker = input.find(kMtlMarker);
  const std::string_view obj = input.substr(0, marker);
  const std::string_view mtl = marker == std::string_view::npos
                                   ? std::string_view()
                                   : input.substr(marker + kMtlMarker.size());
  caustica::fuzz::write_file(scratch.path() / "fuzz.obj", obj);
  caustica::fuzz::write_file(scratch.path() / "fuzz.mtl", mtl);
  const absl::StatusOr<caustica::MeshFile> file =
      caustica::load_mesh_file(scratch.path() / "fuzz.obj");
  if (file.ok()) caustica::fuzz::check_mesh_file(*file);
  return 0;
}
