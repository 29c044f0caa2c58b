// The JSON scene format through parse_scene, as load_scene and `caustica scene upload` read it:
// the JSON reader, every shape, the mesh files and density grids a scene names, and
// validate_scene. Relative file names resolve against a fixture directory in the scratch space
// that holds the test meshes (tests/data/scene/meshes, as ../meshes/) and a small density grid
// (cloud.nvdb, grid "density"), so the seeds from tests/data and scenes/ load as they are.
#include <nanovdb/util/IO.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "fuzz/fuzz_scratch.h"
#include "fuzz/tiny_grid.h"
#include "renderer/scene/load_scene.h"

namespace {

std::filesystem::path make_fixture(const std::filesystem::path& scratch) {
  const std::filesystem::path base_dir = scratch / "good";
  std::filesystem::create_directories(base_dir);
  std::filesystem::copy(std::filesystem::path(CAUSTICA_TEST_DATA) / "scene" / "meshes",
                        scratch / "meshes");
  nanovdb::io::writeGrid<nanovdb::HostBuffer>((base_dir / "cloud.nvdb").string(),
                                              caustica::fuzz::tiny_density_grid());
  return base_dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const caustica::fuzz::ScratchDirectory scratch("scene-json");
  static const std::filesystem::path base_dir = make_fixture(scratch.path());
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  (void)caustica::parse_scene(text, base_dir, "fuzz.json");
  return 0;
}
